//! A deployment state survives JSON unchanged (it is what a saved plan or
//! deployment resumes from): every position, rest length, payout and slip
//! state bit for bit.

mod common;

use common::fixtures::reference_structure;
use tensegrity_deploy::model::{DeploymentState, JointSlip};

#[test]
fn a_deployment_state_round_trips_through_json() {
    let s = reference_structure();
    let mut state = DeploymentState::reference(&s);
    state.payout_m[0] = 0.1 + 0.2;
    state.positions_m[3].z -= 1e-3 / 3.0;
    state.joint_slip[1] = JointSlip::TowardsMotor;
    state.joint_slip[2] = JointSlip::TowardsEnd;
    let text = serde_json::to_string(&state).unwrap();
    let back: DeploymentState = serde_json::from_str(&text).unwrap();
    assert_eq!(back, state);
}
