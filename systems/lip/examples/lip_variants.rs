//! The report's variations side by side on the standard course: `δ = 0` (Peng et al.'s
//! LDCBF) against `δ > 0` (the report's section 5.3.3), and each of our two deviations
//! from the report (unit normal, per-step heading rates) against the report's own form.
//! `docs/lip.md` quotes this table.
//!
//! ```text
//! cargo run --release -p cbfgen-lip --example lip_variants
//! ```

use cbfgen_lip::scenario::{run, Scenario};
use cbfgen_lip::{BarrierForm, HeadingRule, LipParams};

fn main() -> Result<(), cbfgen::CbfError> {
    println!(
        "| course | variant | steps | goal | min CoM clearance [m] | min foot clearance [m] | feet on an obstacle |"
    );
    println!("|---|---|---|---|---|---|---|");
    for (course, scenario) in [("standard", Scenario::standard()), ("corner", Scenario::corner())] {
        table(course, &scenario)?;
    }
    Ok(())
}

fn table(course: &str, base: &Scenario) -> Result<(), cbfgen::CbfError> {
    let d = base.params.delta;
    let variants: [(&str, LipParams); 5] = [
        ("ours: δ = 0.3 m, unit η, per-step ω", base.params),
        ("δ = 0 (Peng et al.)", LipParams { delta: 0.0, ..base.params }),
        (
            "report's η = x − c, δ = 0.09 m²",
            LipParams { barrier: BarrierForm::ReportNormal, delta: d * d, ..base.params },
        ),
        ("report's headings", LipParams { heading: HeadingRule::Report, ..base.params }),
        (
            "report's η and headings",
            LipParams { barrier: BarrierForm::ReportNormal, delta: d * d, heading: HeadingRule::Report, ..base.params },
        ),
    ];
    for (name, params) in variants {
        let r = run(&Scenario { params, ..base.clone() })?;
        println!(
            "| {course} | {name} | {} | {} | {:.3} | {:.3} | {} |",
            r.steps.len(),
            if r.reached_goal { "reached" } else { "not reached" },
            r.min_clearance(),
            r.min_footstep_clearance(),
            r.footsteps_on_obstacles().count()
        );
    }
    Ok(())
}
