//! The two layers at their rates: the MPC re-plans every `δt`, and its desired
//! acceleration is held while the CBF-QP runs every cycle.

use super::barrier::{check_state, SineBarrier, State};
use super::cbf_qp::{CbfQpOutput, CbfQpSettings, IdCbfQp};
use super::mpc::{KinematicMpc, MpcMode, MpcOutput, MpcSettings};
use cbfgen::error::{positive, CbfError};

/// One control cycle's result.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlOutput {
    /// The input applied [m/s²].
    pub u: f64,
    /// The MPC's acceleration held this cycle [m/s²].
    pub desired_accel: f64,
    /// `Some` on the cycles where the MPC re-planned.
    pub mpc: Option<MpcOutput>,
    /// The CBF-QP's solution this cycle; its `u` is the input applied.
    pub qp: CbfQpOutput,
}

/// MPC (low rate) → held acceleration → ID-CBF-QP (every cycle).
#[derive(Debug)]
pub struct MultiLayerController {
    mpc: KinematicMpc,
    qp: IdCbfQp,
    /// Control cycles per MPC re-plan.
    mpc_every: u64,
    cycle: u64,
    held_accel: f64,
}

impl MultiLayerController {
    /// `cycle_dt` is the high-rate period; the MPC's sample time must be a whole number
    /// of cycles.
    ///
    /// # Errors
    /// Invalid settings, or `mpc.dt` not a multiple of `cycle_dt`.
    pub fn new(
        barrier: SineBarrier,
        mode: MpcMode,
        mpc: MpcSettings,
        qp: CbfQpSettings,
        cycle_dt: f64,
    ) -> Result<Self, CbfError> {
        positive("control period", cycle_dt)?;
        let ratio = mpc.dt / cycle_dt;
        if !(ratio >= 1.0 && (ratio - ratio.round()).abs() < 1e-9) {
            return Err(CbfError::OutOfRange {
                what: "MPC period / control period",
                value: ratio,
                range: "whole numbers ≥ 1",
            });
        }
        Ok(Self {
            mpc: KinematicMpc::new(mpc, mode, barrier)?,
            qp: IdCbfQp::new(qp, barrier)?,
            mpc_every: ratio.round() as u64,
            cycle: 0,
            held_accel: 0.0,
        })
    }

    /// The low-rate layer (its last plan, mode and settings).
    pub fn mpc(&self) -> &KinematicMpc {
        &self.mpc
    }

    /// One cycle at time `t` from state `x`. Does not allocate.
    ///
    /// # Errors
    /// `x` or `t` not finite, or either QP without a usable iterate. Nothing advances
    /// then: the next call retries the same cycle.
    pub fn control(&mut self, t: f64, x: &State) -> Result<ControlOutput, CbfError> {
        check_state(x, t)?;
        let mpc = if self.cycle.is_multiple_of(self.mpc_every) { Some(self.mpc.solve(t, x)?) } else { None };
        let desired_accel = mpc.map_or(self.held_accel, |m| m.desired_accel);
        let qp = self.qp.solve(t, x, desired_accel)?;
        self.held_accel = desired_accel;
        self.cycle += 1;
        Ok(ControlOutput { u: qp.u, desired_accel, mpc, qp })
    }
}
