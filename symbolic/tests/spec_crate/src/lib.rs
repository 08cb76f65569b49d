//! Six systems generated at build time by cbfgen-build.

/// A planar robot with a speed limit (degree 1) and box walls (degree 2).
pub mod planar_robot {
    cbfgen::include_system!("planar_robot");
}

/// The triple integrator below a position limit (degree 3).
pub mod triple_integrator {
    cbfgen::include_system!("triple_integrator");
}

/// A planar robot whose parameters take their domains from the primitives.
pub mod boxed_robot {
    cbfgen::include_system!("boxed_robot");
}

/// A planar quadrotor whose speed limit, through thrust alone, can starve its floor.
pub mod planar_quadrotor {
    cbfgen::include_system!("planar_quadrotor");
}

/// Adaptive cruise control: a CLF below two CBFs, one with an extended class-K term.
pub mod adaptive_cruise {
    cbfgen::include_system!("adaptive_cruise");
}

/// A planar robot whose filter cost is a state-dependent quadratic (a spec objective).
pub mod drag_weighted_robot {
    cbfgen::include_system!("drag_weighted_robot");
}
