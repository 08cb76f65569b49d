//! A run played back: one self-contained HTML page (no script or style fetched from
//! anywhere) drawing the side view of every run of a course, one above the other on one
//! clock: the terrain and the riser boxes the filter avoids (nosing and riser of each
//! change of height, [`Terrain::riser_boxes`]), the body box, the legs, the toe wheels, with
//! the time, the smallest `h`, the body's exact clearance to the solid terrain and the active rows as a
//! ticker. A run on perceived terrain also shows, at each moment, the ground and edge
//! cuboids its latest perception update gave the gait and filter, over the true ones.
//! Play, pause, scrub and speed are on the page; `page.html#N` opens at frame N.

use std::fmt::Write as _;

use super::{SimResult, DT};
use crate::catalog::Family;
use crate::generated as gen;
use crate::model::{HIP_POSITIONS, TOE_RADIUS};
use crate::terrain::{Profile, Terrain};
use cbfgen::error::CbfError;
use cbfgen::geometry::OrientedBox;

/// Simulated time between frames \[s\] (25 frames per simulated second).
pub const FRAME_PERIOD: f64 = 0.04;

/// The page and how many frames its longest run has.
#[derive(Debug, Clone, PartialEq)]
pub struct Animation {
    /// The HTML document.
    pub html: String,
    /// Frames of the longest run; a shorter run holds its last frame.
    pub frames: usize,
}

/// The animation of `runs` (label, run) on `terrain`.
///
/// # Errors
/// A terrain whose riser boxes cannot be built (never, for one built by [`Terrain::new`]).
pub fn animation(runs: &[(&str, &SimResult)], terrain: &Terrain) -> Result<Animation, CbfError> {
    let every = (FRAME_PERIOD / DT).round() as usize;
    let mut data = String::new();
    let frames = runs.iter().map(|(_, r)| r.samples.len().div_ceil(every)).max().unwrap_or(0);
    let _ = write!(data, r#"{{"frames":{frames},"period":{FRAME_PERIOD},"toe_radius":{TOE_RADIUS},"ground":["#);
    let (first, last) = (terrain.first_change() - 3.0, terrain.profile().last_change() + 3.0);
    data.push_str(&ground_line(terrain.profile(), first, last));
    data.push_str(r#"],"edges":["#);
    data.push_str(&join(terrain.riser_boxes()?.iter().map(side_rect)));
    data.push_str(r#"],"runs":["#);
    for (k, (label, run)) in runs.iter().enumerate() {
        let picked: Vec<_> = run.samples.iter().step_by(every).collect();
        let _ = write!(
            data,
            r#"{}{{"label":"{}","frames":{},"t":[{}],"body":[{}],"hips":[{}],"toes":[{}],"#,
            if k == 0 { "" } else { "," },
            label.replace('"', "'"),
            picked.len(),
            join(picked.iter().map(|s| num(s.t))),
            join(picked.iter().map(|s| side_view(&s.x).0)),
            join(picked.iter().map(|s| side_view(&s.x).1)),
            join(picked.iter().map(|s| side_view(&s.x).2)),
        );
        let _ = write!(
            data,
            r#""h_body":[{}],"h_min":[{}],"clearance":[{}],"rows":[{}]"#,
            join(picked.iter().map(|s| num(s.min_h[Family::BodyEdge.index()]))),
            join(picked.iter().map(|s| num(s.min_h.iter().copied().fold(f64::INFINITY, f64::min)))),
            join(picked.iter().map(|s| num(s.clearance.body.distance))),
            join(picked.iter().map(|s| s.active_rows.to_string())),
        );
        // On perceived terrain: what each update handed the gait and filter, from when.
        if let Some(perception) = &run.perception {
            let updates = perception.updates.iter().map(|u| {
                format!(
                    r#"{{"t":{},"ground":[{}],"edges":[{}]}}"#,
                    num(u.applied_at),
                    ground_line(&u.ground, first, last),
                    join(u.edges.iter().map(side_rect))
                )
            });
            let _ = write!(data, r#","perceived":[{}]"#, join(updates));
        }
        data.push('}');
    }
    data.push_str("]}");
    let title = runs.first().map_or("run", |(_, r)| r.summary.scenario.name());
    let html = PAGE.replace("{{TITLE}}", title).replace("{{DATA}}", &data);
    Ok(Animation { html, frames })
}

/// The profile's levels as a polyline `[x, z]` from `first` to `last` (its infinite
/// ends cut there).
fn ground_line(profile: &Profile, first: f64, last: f64) -> String {
    join(profile.levels().iter().filter(|l| l.end > first && l.begin < last).map(|l| {
        let (begin, end) = (l.begin.max(first), l.end.min(last));
        format!("[{},{}],[{},{}]", num(begin), num(l.height), num(end), num(l.height))
    }))
}

/// A box's side view `[cx, cz, hx, hz]`: the rectangle bounding its projection on the
/// x–z plane (exact for a box with an axis along y, as edges are).
fn side_rect(b: &OrientedBox) -> String {
    let (r, h, c) = (b.rotation().matrix(), b.half_extents(), b.center());
    let reach = |i: usize| (0..3).map(|j| r[(i, j)].abs() * h[j]).sum::<f64>();
    format!("[{},{},{},{}]", num(c.x), num(c.z), num(reach(0)), num(reach(2)))
}

/// `(body corners, hips, toes)` in the side view (x, z), flattened as JSON arrays.
fn side_view(x: &[f64; gen::NX]) -> (String, String, String) {
    let (center, rotation, toes) = gen::world_kinematics(x);
    let world = |p: [f64; 3]| {
        let r = |i: usize| rotation[i][0] * p[0] + rotation[i][1] * p[1] + rotation[i][2] * p[2];
        (center[0] + r(0), center[2] + r(2))
    };
    let [hx, _, hz] = gen::BODY_HALF_EXTENTS;
    let corners = [[hx, 0.0, hz], [hx, 0.0, -hz], [-hx, 0.0, -hz], [-hx, 0.0, hz]].map(world);
    let hips = HIP_POSITIONS.map(world);
    let pairs = |points: &[(f64, f64)]| format!("[{}]", join(points.iter().flat_map(|&(x, z)| [num(x), num(z)])));
    let toes: Vec<(f64, f64)> = toes.iter().map(|t| (t[0], t[2])).collect();
    (pairs(&corners), pairs(&hips), pairs(&toes))
}

/// A JSON number to 0.1 mm, or `null` where not finite.
fn num(v: f64) -> String {
    if v.is_finite() {
        let s = format!("{v:.4}");
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        "null".into()
    }
}

fn join(items: impl Iterator<Item = String>) -> String {
    items.collect::<Vec<_>>().join(",")
}

const PAGE: &str = r##"<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>cbfgen: {{TITLE}}</title>
<style>
body { font: 14px sans-serif; margin: 16px; color: #222; }
canvas { border: 1px solid #ccc; display: block; margin-top: 4px; }
.ticker { font-family: monospace; margin: 2px 0 14px; white-space: pre-wrap; max-width: 960px; }
.controls { margin-bottom: 10px; }
</style></head><body>
<h2>cbfgen: {{TITLE}}, side view</h2>
<div class="controls"><button id="play">pause</button>
<input id="scrub" type="range" min="0" value="0" style="width:480px">
<select id="speed"><option value="1">1×</option><option value="2" selected>2×</option><option value="4">4×</option></select>
<span id="time"></span></div>
<div id="runs"></div>
<script type="application/json" id="data">{{DATA}}</script>
<script>
const data = JSON.parse(document.getElementById("data").textContent);
const W = 960, pad = 20;
let xs = [], zs = [];
for (const [x, z] of data.ground) { xs.push(x); zs.push(z); }
for (const run of data.runs) for (const b of run.body) for (let i = 0; i < 8; i += 2) { xs.push(b[i]); zs.push(b[i + 1]); }
const x0 = Math.min(...xs) - 0.2, x1 = Math.max(...xs) + 0.2, z0 = Math.min(...zs) - 0.15, z1 = Math.max(...zs) + 0.3;
const s = (W - 2 * pad) / (x1 - x0), H = Math.ceil((z1 - z0) * s + 2 * pad);
const px = x => pad + (x - x0) * s, pz = z => H - pad - (z - z0) * s;
const views = data.runs.map(run => {
  const title = document.createElement("div");
  title.textContent = run.label + (run.perceived ? " (on perceived terrain: true terrain and edge cuboids filled, what perception gave the filter in green outline)" : "");
  const canvas = document.createElement("canvas"); canvas.width = W; canvas.height = H;
  const ticker = document.createElement("div"); ticker.className = "ticker";
  document.getElementById("runs").append(title, canvas, ticker);
  return { run, ctx: canvas.getContext("2d"), ticker };
});
const fmt = (v, unit, k, digits) => v === null ? "—" : (v * k).toFixed(digits) + unit;
function draw(frame) {
  for (const { run, ctx, ticker } of views) {
    const f = Math.min(frame, run.frames - 1);
    ctx.clearRect(0, 0, W, H);
    ctx.fillStyle = "#e9e4dc"; ctx.strokeStyle = "#555"; ctx.lineWidth = 1.5;
    ctx.beginPath(); ctx.moveTo(px(data.ground[0][0]), pz(z0));
    for (const [x, z] of data.ground) ctx.lineTo(px(x), pz(z));
    ctx.lineTo(px(data.ground[data.ground.length - 1][0]), pz(z0)); ctx.closePath(); ctx.fill(); ctx.stroke();
    ctx.fillStyle = "rgba(220,60,60,0.55)";
    for (const [cx, cz, hx, hz] of data.edges) ctx.fillRect(px(cx - hx), pz(cz + hz), 2 * hx * s, 2 * hz * s);
    // On perceived terrain, what the gait and filter saw: the latest update applied.
    let seen = null;
    for (const u of run.perceived || []) if (u.t <= run.t[f] + 1e-9) seen = u;
    if (seen) {
      ctx.strokeStyle = "rgba(20,140,60,0.95)"; ctx.lineWidth = 1.5; ctx.setLineDash([6, 4]);
      ctx.beginPath();
      seen.ground.forEach(([x, z], i) => i === 0 ? ctx.moveTo(px(x), pz(z)) : ctx.lineTo(px(x), pz(z)));
      ctx.stroke(); ctx.setLineDash([]);
      for (const [cx, cz, hx, hz] of seen.edges) ctx.strokeRect(px(cx - hx), pz(cz + hz), 2 * hx * s, 2 * hz * s);
    }
    const body = run.body[f], hips = run.hips[f], toes = run.toes[f];
    const touching = run.clearance[f] !== null && run.clearance[f] < 0;
    ctx.strokeStyle = "#444"; ctx.lineWidth = 3;
    for (let k = 0; k < 6; k++) { ctx.beginPath(); ctx.moveTo(px(hips[2 * k]), pz(hips[2 * k + 1])); ctx.lineTo(px(toes[2 * k]), pz(toes[2 * k + 1])); ctx.stroke(); }
    ctx.fillStyle = touching ? "rgba(220,30,30,0.8)" : "rgba(50,105,180,0.85)";
    ctx.beginPath(); ctx.moveTo(px(body[0]), pz(body[1]));
    for (let i = 2; i < 8; i += 2) ctx.lineTo(px(body[i]), pz(body[i + 1]));
    ctx.closePath(); ctx.fill();
    ctx.fillStyle = "rgba(30,30,30,0.75)";
    for (let k = 0; k < 6; k++) { ctx.beginPath(); ctx.arc(px(toes[2 * k]), pz(toes[2 * k + 1]), data.toe_radius * s, 0, 2 * Math.PI); ctx.fill(); }
    ticker.textContent = `t ${run.t[f].toFixed(2)} s  min h: body–edge ${fmt(run.h_body[f], "", 1, 4)}, all rows ${fmt(run.h_min[f], "", 1, 4)}  body clearance ${fmt(run.clearance[f], " mm", 1000, 1)}  active rows ${run.rows[f]}` + (seen ? `  perceived: ${seen.edges.length} cuboids, update at ${seen.t.toFixed(1)} s` : "") + (touching ? "  BODY IN THE TERRAIN" : "");
  }
  document.getElementById("time").textContent = `frame ${frame + 1} of ${data.frames}`;
}
const scrub = document.getElementById("scrub"); scrub.max = data.frames - 1;
// A page opened at #N starts at frame N, paused.
let frame = Math.min(data.frames - 1, Math.max(0, Math.floor(+location.hash.slice(1)) || 0));
let clock = frame * data.period, playing = frame === 0, last = null;
const play = document.getElementById("play");
play.onclick = () => {
  if (!playing && frame >= data.frames - 1) { frame = 0; clock = 0; }
  playing = !playing; play.textContent = playing ? "pause" : "play";
};
scrub.oninput = () => { frame = +scrub.value; clock = frame * data.period; draw(frame); };
function tick(now) {
  if (playing && last !== null) {
    clock += (now - last) / 1000 * +document.getElementById("speed").value;
    frame = Math.min(data.frames - 1, Math.floor(clock / data.period));
    if (frame >= data.frames - 1) { playing = false; play.textContent = "play"; }
    scrub.value = frame; draw(frame);
  }
  last = playing ? now : null;
  requestAnimationFrame(tick);
}
play.textContent = playing ? "pause" : "play"; scrub.value = frame;
draw(frame); requestAnimationFrame(tick);
</script></body></html>
"##;
