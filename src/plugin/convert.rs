//! The core's plain data to and from its C form, for both sides of the boundary.

use std::time::Duration;

use super::{
    code, decode, CauseC, DomainC, ErrorC, ErrorCode, FamilyParamsC, SafetyC, SolverC, StrC, SOLVERS, VERDICTS,
};
use crate::error::CbfError;
use crate::filter::{Cause, Limit, RelaxedRow, Safety, Verdict};
use crate::param_domain::Domain;
use crate::qp::SolverSettings;
use crate::system::{ClassK, FamilyParams, Poles, MAX_RELATIVE_DEGREE};

/// An error with `code` and `message` into the other side's buffer (a message longer than
/// the buffer is cut at a character).
pub(super) fn write_error(code: ErrorCode, message: &str, out: *mut ErrorC) {
    // SAFETY: the caller passed a valid, exclusive ErrorC, or null.
    let Some(out) = (unsafe { out.as_mut() }) else { return };
    let mut len = message.len().min(super::ERROR_CAPACITY);
    while !message.is_char_boundary(len) {
        len -= 1;
    }
    out.text[..len].copy_from_slice(&message.as_bytes()[..len]);
    out.len = len;
    out.code = code as u32;
}

/// The error in `err`: the plugin's as its message, but for the one error without fields,
/// [`CbfError::CapacityMismatch`], which is itself again (the plugin's core is this one:
/// the loader checked the version), so callers can tell it and name its fix.
pub(super) fn read_error(err: &ErrorC) -> CbfError {
    if err.code == ErrorCode::CapacityMismatch as u32 {
        return CbfError::CapacityMismatch;
    }
    let text = &err.text[..err.len.min(super::ERROR_CAPACITY)];
    CbfError::Plugin { message: String::from_utf8_lossy(text).into_owned() }
}

/// A string the plugin keeps for as long as it is loaded.
///
/// # Safety
/// `s` points to `len` bytes of UTF-8 that live as long as the process.
pub(super) unsafe fn static_str(s: StrC) -> &'static str {
    if s.len == 0 {
        return "";
    }
    // SAFETY: as the caller promises.
    unsafe { std::str::from_utf8_unchecked(std::slice::from_raw_parts(s.ptr, s.len)) }
}

pub(super) fn domain_c(d: Domain) -> DomainC {
    let (kind, a, b) = match d {
        Domain::Real => (0, 0.0, 0.0),
        Domain::Positive => (1, 0.0, 0.0),
        Domain::NonNegative => (2, 0.0, 0.0),
        Domain::Interval { lo, hi } => (3, lo, hi),
        Domain::UnitVector { tolerance } => (4, tolerance, 0.0),
        Domain::Rotation { tolerance } => (5, tolerance, 0.0),
    };
    DomainC { kind, a, b }
}

pub(super) fn domain(d: DomainC) -> Domain {
    match d.kind {
        1 => Domain::Positive,
        2 => Domain::NonNegative,
        3 => Domain::Interval { lo: d.a, hi: d.b },
        4 => Domain::UnitVector { tolerance: d.a },
        5 => Domain::Rotation { tolerance: d.a },
        _ => Domain::Real,
    }
}

pub(super) fn family_params_c(p: &FamilyParams) -> FamilyParamsC {
    let mut poles = [0.0; MAX_RELATIVE_DEGREE];
    poles[..p.poles.len()].copy_from_slice(p.poles.as_slice());
    FamilyParamsC {
        poles,
        n_poles: p.poles.len(),
        priority: p.priority,
        activation: p.activation,
        class_k: StrC::new(p.class_k.name()),
    }
}

/// `p`, its class-K function found by name among `known` (the system's own).
///
/// # Safety
/// `p.class_k` is a valid string for the duration of the call.
pub(super) unsafe fn family_params(
    p: &FamilyParamsC,
    known: impl Iterator<Item = ClassK>,
) -> Result<FamilyParams, CbfError> {
    let n = p.n_poles.min(MAX_RELATIVE_DEGREE);
    // SAFETY: as the caller promises (read, not kept).
    let name = unsafe { std::slice::from_raw_parts(p.class_k.ptr, p.class_k.len) };
    let class_k =
        std::iter::once(ClassK::LINEAR).chain(known).find(|k| k.name().as_bytes() == name).ok_or_else(|| {
            CbfError::Plugin {
                message: format!("class-K function {:?} is not one of this system's", String::from_utf8_lossy(name)),
            }
        })?;
    Ok(FamilyParams { poles: Poles::new(&p.poles[..n])?, priority: p.priority, activation: p.activation, class_k })
}

pub(super) fn solver_c(s: &SolverSettings) -> SolverC {
    SolverC {
        backend: code(&SOLVERS, &s.backend),
        dense_max_steps: s.dense_max_steps,
        dense_max_work: s.dense_max_work,
        eps_abs: s.eps_abs,
        eps_rel: s.eps_rel,
        max_iter: s.max_iter,
        rho: s.rho,
        sigma: s.sigma,
        alpha: s.alpha,
        adaptive_rho: s.adaptive_rho,
        adaptive_rho_interval: s.adaptive_rho_interval,
        check_termination: s.check_termination,
        time_limit_ns: s.time_limit.map_or(-1, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX)),
        polish: s.polish,
        scaling: s.scaling,
    }
}

pub(super) fn solver(s: &SolverC) -> SolverSettings {
    SolverSettings {
        backend: decode(&SOLVERS, i64::from(s.backend)).unwrap_or_default(),
        dense_max_steps: s.dense_max_steps,
        dense_max_work: s.dense_max_work,
        eps_abs: s.eps_abs,
        eps_rel: s.eps_rel,
        max_iter: s.max_iter,
        rho: s.rho,
        sigma: s.sigma,
        alpha: s.alpha,
        adaptive_rho: s.adaptive_rho,
        adaptive_rho_interval: s.adaptive_rho_interval,
        check_termination: s.check_termination,
        time_limit: u64::try_from(s.time_limit_ns).ok().map(Duration::from_nanos),
        polish: s.polish,
        scaling: s.scaling,
    }
}

pub(super) fn cause_c(c: Option<Cause>) -> CauseC {
    match c {
        None => CauseC::default(),
        Some(Cause::NoAuthority) => CauseC { kind: 1, ..CauseC::default() },
        Some(Cause::InputLimit { input, limit }) => {
            CauseC { kind: 2, index: input, limit: u8::from(limit == Limit::Max) }
        }
        Some(Cause::HigherPriority { row }) => CauseC { kind: 3, index: row, limit: 0 },
        Some(Cause::SamePriority { row }) => CauseC { kind: 4, index: row, limit: 0 },
        Some(Cause::Unsolved) => CauseC { kind: 5, ..CauseC::default() },
    }
}

pub(super) fn cause(c: CauseC) -> Option<Cause> {
    match c.kind {
        1 => Some(Cause::NoAuthority),
        2 => Some(Cause::InputLimit { input: c.index, limit: if c.limit == 1 { Limit::Max } else { Limit::Min } }),
        3 => Some(Cause::HigherPriority { row: c.index }),
        4 => Some(Cause::SamePriority { row: c.index }),
        5 => Some(Cause::Unsolved),
        _ => None,
    }
}

pub(super) fn safety_c(s: &Safety) -> SafetyC {
    let mut out = SafetyC { verdict: code(&VERDICTS, &s.verdict), relaxed_rows: s.relaxed_rows, ..SafetyC::default() };
    if let Some(w) = s.worst {
        (out.worst_row, out.worst_family, out.worst_slack, out.worst_relative) = (w.row, w.family, w.slack, w.relative);
        out.worst_cause = cause_c(Some(w.cause));
    }
    out
}

pub(super) fn safety(s: &SafetyC) -> Safety {
    Safety {
        verdict: decode(&VERDICTS, i64::from(s.verdict)).unwrap_or(Verdict::Unassessed),
        relaxed_rows: s.relaxed_rows,
        worst: cause(s.worst_cause).map(|cause| RelaxedRow {
            row: s.worst_row,
            family: s.worst_family,
            slack: s.worst_slack,
            relative: s.worst_relative,
            cause,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_value_crosses_the_boundary_and_back_unchanged() {
        let causes = [
            None,
            Some(Cause::NoAuthority),
            Some(Cause::InputLimit { input: 3, limit: Limit::Min }),
            Some(Cause::InputLimit { input: 0, limit: Limit::Max }),
            Some(Cause::HigherPriority { row: 17 }),
            Some(Cause::SamePriority { row: 2 }),
            Some(Cause::Unsolved),
        ];
        for c in causes {
            assert_eq!(cause(cause_c(c)), c);
        }
        let domains = [
            Domain::Real,
            Domain::Positive,
            Domain::NonNegative,
            Domain::Interval { lo: -1.5, hi: 2.0 },
            Domain::UnitVector { tolerance: 1e-9 },
            Domain::Rotation { tolerance: 1e-6 },
        ];
        for d in domains {
            assert_eq!(domain(domain_c(d)), d);
        }
        let mut s = SolverSettings { time_limit: Some(Duration::from_micros(250)), ..SolverSettings::default() };
        for backend in SOLVERS {
            s.backend = backend;
            s.polish = !s.polish;
            assert_eq!(solver(&solver_c(&s)), s);
        }
        let worst =
            RelaxedRow { row: 4, family: 1, slack: 0.25, relative: 1e-3, cause: Cause::HigherPriority { row: 0 } };
        for safe in [
            Safety::UNASSESSED,
            Safety { verdict: Verdict::Met, relaxed_rows: 0, worst: None },
            Safety { verdict: Verdict::Relaxed, relaxed_rows: 2, worst: Some(worst) },
        ] {
            assert_eq!(safety(&safety_c(&safe)), safe);
        }
        let cube = ClassK::extended("s**3", |s| s * s * s);
        let p = FamilyParams { poles: Poles::from([2.0, 3.0]), priority: 4, activation: 0.5, class_k: cube };
        // SAFETY: the class-K name is a static string.
        assert_eq!(unsafe { family_params(&family_params_c(&p), [cube].into_iter()) }.unwrap(), p);
        let unknown = unsafe { family_params(&family_params_c(&p), std::iter::empty()) }.unwrap_err();
        assert!(unknown.to_string().contains("\"s**3\" is not one of this system's"), "{unknown}");
        let mut err = super::super::ErrorC::new();
        let negative = CbfError::NotPositive { what: "input weight", value: -1.0 };
        write_error(ErrorCode::of(&negative), &negative.to_string(), &mut err);
        assert_eq!(err.code, 2, "the code of NotPositive, as cbfgen.h numbers it");
        assert_eq!(read_error(&err).to_string(), negative.to_string());
        assert!(matches!(read_error(&err), CbfError::Plugin { .. }));
        // The one error without fields comes back as itself, by its code.
        write_error(ErrorCode::CapacityMismatch, &CbfError::CapacityMismatch.to_string(), &mut err);
        assert!(matches!(read_error(&err), CbfError::CapacityMismatch));
        // A message longer than the buffer is cut at a character, never inside one.
        let long = "é".repeat(super::super::ERROR_CAPACITY);
        write_error(ErrorCode::Plugin, &long, &mut err);
        assert_eq!(err.len, super::super::ERROR_CAPACITY);
        assert!(std::str::from_utf8(&err.text[..err.len]).is_ok());
    }
}
