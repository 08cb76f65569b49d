//! The sizes and magnitudes every system lives within, in one place that imports nothing
//! (re-exported by [`system`](crate::system), where users find them).

/// Highest relative degree a family may have (the symbolic stage stops looking there).
pub const MAX_RELATIVE_DEGREE: usize = 4;

/// Largest capacity of one capacity-sized family: a bound on rows laid out, so an absurd
/// capacity is a typed error instead of an allocation failure.
pub const MAX_INSTANCES: usize = 10_000;

/// Largest |state entry| a barrier set evaluates at (metres, radians and their rates, for
/// every system): 100 km, far past any course, and far from where a generated row's
/// squares and products overflow. World numbers in the same units (floors, goals, planes)
/// share it.
pub const STATE_LIMIT: f64 = 1e5;

/// Largest |runtime parameter| a generated barrier set accepts (positions, sizes, gains of
/// a boundary, in the parameter's own units); parameters are checked every evaluation.
pub const PARAM_LIMIT: f64 = 1e6;

/// Largest |t| \[s\] a time-varying barrier accepts: about 30 years of run time, and far
/// below where `sin(ω t)` loses every digit.
pub const TIME_LIMIT: f64 = 1e9;
