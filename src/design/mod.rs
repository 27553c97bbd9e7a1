//! Design tools: structures to run the model on. The reference footbridge
//! ([`reference_bridge()`]), its stability-constrained prestress
//! ([`form_finding`]), the seed's friction test rig ([`friction_rig`]) and
//! the peer benchmark's cable net ([`square_net()`]).

pub mod form_finding;
pub mod friction_rig;
pub mod reference_bridge;
pub mod square_net;

pub use reference_bridge::{
    reference_bridge, BridgeError, BridgeParameters, BridgeTopology, SpringPlacement,
    MAX_MODULES_PER_HALF,
};
pub use square_net::{square_net, SquareNetParameters};
