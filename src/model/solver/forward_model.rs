//! The forward model: a structure with its joint friction and solver
//! settings, and the caches derived from them once (element list, loads,
//! free-DOF numbering and blocks).

use nalgebra::Vector3;

use super::element::{Element, ElementLaw};
use super::settings::{RelaxSettings, SettingsError};
use crate::model::cable_seats::seat_material_m;
use crate::model::friction::JointFriction;
use crate::model::state::DeploymentState;
use crate::model::structure::Structure;
#[allow(unused_imports)] // named in docs
use crate::numerics::BlockLu;
use crate::numerics::FreeDofs;

/// A structure with its joint friction and solver settings: the forward model.
#[derive(Debug, Clone)]
///
/// Its parts are read-only once built, so the element list and other
/// caches derived from them can never go stale; build a new model to change
/// one.
pub struct ForwardModel {
    pub(in crate::model) structure: Structure,
    pub(in crate::model) friction: JointFriction,
    pub(in crate::model) settings: RelaxSettings,
    pub(in crate::model) elements: Vec<Element>,
    pub(super) external_n: Vec<Vector3<f64>>,
    pub(super) free_mask: Vec<Vector3<f64>>,
    pub(super) size_m: f64,
    pub(super) free_dofs: FreeDofs,
    pub(super) dof_blocks: Vec<Vec<usize>>,
    /// How tangents are stored and factorised (dense or sparse blocks),
    /// made at the first Newton solve: see `ForwardModel::tangent_layout`.
    pub(super) tangent_layout: std::sync::OnceLock<crate::numerics::BlockLayout>,
    /// Radius of the cable's arc on the joint seats, m, where the model
    /// follows the seats ([`Self::with_cable_seats`]); `None`: the cables
    /// pass through the joint centres.
    pub(super) seat_radius_m: Option<f64>,
}

/// Forces in every member and segment of a state.
#[derive(Debug, Clone, PartialEq)]
pub struct MemberForces {
    /// Axial force of each member (tension positive), N, as [`Structure::members`].
    pub member_n: Vec<f64>,
    /// Tension of each continuous-cable segment, N, flat as the state's segments.
    pub segment_n: Vec<f64>,
    /// Current length of each member, m.
    pub member_length_m: Vec<f64>,
    /// Current length of each segment, m.
    pub segment_length_m: Vec<f64>,
    /// Support reaction at each node (zero on free DOFs), N.
    pub reaction_n: Vec<Vector3<f64>>,
}

impl ForwardModel {
    /// Builds the model; cheap, and it precomputes the element list. The
    /// structure and friction are valid by construction; the settings are
    /// checked here.
    pub fn new(
        structure: Structure,
        friction: JointFriction,
        settings: RelaxSettings,
    ) -> Result<Self, SettingsError> {
        settings.validate()?;
        let mut elements = Vec::with_capacity(structure.members.len() + structure.segment_count());
        for m in &structure.members {
            elements.push(Element {
                a: m.nodes[0],
                b: m.nodes[1],
                law: ElementLaw::Linear {
                    stiffness_n_per_m: m.kind.axial_stiffness(m.rest_length_m),
                    rest_m: m.rest_length_m,
                    tension_only: m.kind.is_tension_only(),
                },
            });
        }
        let mut index = 0;
        for c in &structure.continuous_cables {
            for w in c.path.windows(2) {
                elements.push(Element {
                    a: w[0],
                    b: w[1],
                    law: ElementLaw::Segment {
                        ea_n: c.ea_n,
                        index,
                    },
                });
                index += 1;
            }
        }
        let external_n = structure
            .nodes
            .iter()
            .map(|n| n.mass_kg * structure.gravity_m_per_s2 + n.load_n)
            .collect();
        let free_mask = structure
            .nodes
            .iter()
            .map(|n| n.fixed.map(|f| if f { 0.0 } else { 1.0 }).into())
            .collect();
        let (mut lo, mut hi) = (Vector3::repeat(f64::MAX), Vector3::repeat(f64::MIN));
        for n in &structure.nodes {
            lo = lo.inf(&n.position_m);
            hi = hi.sup(&n.position_m);
        }
        let size_m = (hi - lo).norm().max(1e-3);
        let free_dofs = FreeDofs::from_fixed(structure.nodes.iter().map(|n| &n.fixed));
        // A cluster of sliding joints couples every node of its cable, a
        // support on the path included: a cable's free nodes form one
        // chain whatever lies between them (its windows alone would split
        // the cable at a fixed joint and drop the coupling).
        let cable_free_nodes: Vec<Vec<usize>> = structure
            .continuous_cables
            .iter()
            .map(|c| {
                c.path
                    .iter()
                    .copied()
                    .filter(|&n| structure.nodes[n].is_free())
                    .collect()
            })
            .collect();
        let dof_blocks = free_dofs.blocks(
            structure.members.iter().map(|m| m.nodes).chain(
                cable_free_nodes
                    .iter()
                    .flat_map(|path| path.windows(2).map(|w| [w[0], w[1]])),
            ),
        );
        Ok(ForwardModel {
            structure,
            friction,
            settings,
            elements,
            external_n,
            free_mask,
            size_m,
            free_dofs,
            dof_blocks,
            tangent_layout: std::sync::OnceLock::new(),
            seat_radius_m: None,
        })
    }

    /// This model with the continuous cables running over cable seats of
    /// radius `seat_radius_m` (m, finite, ≥ 0) around the joint centres
    /// (joint eccentricity, [`crate::model::cable_seats`]): every increment
    /// of a command moves the material the seat arcs took, and every
    /// command ends with the arcs followed to their fixed point
    /// ([`Self::follow_seats`]).
    pub fn with_cable_seats(mut self, seat_radius_m: f64) -> Result<Self, SettingsError> {
        if !(seat_radius_m >= 0.0 && seat_radius_m.is_finite()) {
            return Err(SettingsError {
                field: "seat_radius_m".into(),
                reason: format!("must be a finite number in [0, ∞), got {seat_radius_m}"),
            });
        }
        self.seat_radius_m = Some(seat_radius_m);
        Ok(self)
    }

    /// Radius of the cable seats this model follows, m (`None`: the
    /// cables pass through the joint centres).
    pub fn cable_seat_radius_m(&self) -> Option<f64> {
        self.seat_radius_m
    }

    /// The structure.
    pub fn structure(&self) -> &Structure {
        &self.structure
    }

    /// Joint friction of all continuous cables.
    pub fn friction(&self) -> &JointFriction {
        &self.friction
    }

    /// Solver settings.
    pub fn settings(&self) -> &RelaxSettings {
        &self.settings
    }

    /// The as-built state of this model's structure.
    ///
    /// With cable seats the as-built arcs are wrapped already (the cable
    /// was cut to the design prestress on the real joints): the state
    /// holds them, and only changes of the wrap angles move material.
    pub fn reference_state(&self) -> DeploymentState {
        let mut state = DeploymentState::reference(&self.structure);
        if let Some(r) = self.seat_radius_m {
            state.seat_material_m = seat_material_m(&self.structure, &state.positions_m, r);
        }
        state
    }

    /// Number of free degrees of freedom.
    pub(super) fn free_dof_count(&self) -> usize {
        self.structure
            .nodes
            .iter()
            .map(|n| n.fixed.iter().filter(|f| !**f).count())
            .sum()
    }

    /// Numbering of the free degrees of freedom, as in every matrix the
    /// model builds.
    pub fn free_dofs(&self) -> &FreeDofs {
        &self.free_dofs
    }

    /// Free DOFs (numbered as [`Self::free_dofs`]) in blocks that no
    /// member or cable couples: parts of the structure that move
    /// independently (see [`BlockLu`]).
    pub fn dof_blocks(&self) -> &[Vec<usize>] {
        &self.dof_blocks
    }

    /// Bounding-box diagonal of the as-built structure, m.
    pub(super) fn size_m(&self) -> f64 {
        self.size_m
    }

    /// Member and segment forces and support reactions of a state.
    ///
    /// Does not relax or slide anything: it reads the state as it is.
    pub fn member_forces(&self, state: &DeploymentState) -> MemberForces {
        let x = &state.positions_m;
        let n_members = self.structure.members.len();
        let n_seg = state.segment_rest_lengths_m.len();
        let mut out = MemberForces {
            member_n: vec![0.0; n_members],
            segment_n: vec![0.0; n_seg],
            member_length_m: vec![0.0; n_members],
            segment_length_m: vec![0.0; n_seg],
            reaction_n: vec![Vector3::zeros(); x.len()],
        };
        let mut net = self.external_n.clone();
        for (k, e) in self.elements.iter().enumerate() {
            let d = x[e.b] - x[e.a];
            let l = d.norm();
            let t = e.law.at(l, &state.segment_rest_lengths_m).tension_n;
            match e.law {
                ElementLaw::Linear { .. } => {
                    out.member_n[k] = t;
                    out.member_length_m[k] = l;
                }
                ElementLaw::Segment { index, .. } => {
                    out.segment_n[index] = t;
                    out.segment_length_m[index] = l;
                }
            }
            let f = t * d / l;
            net[e.a] += f;
            net[e.b] -= f;
        }
        for (i, node) in self.structure.nodes.iter().enumerate() {
            for a in 0..3 {
                if node.fixed[a] {
                    out.reaction_n[i][a] = -net[i][a];
                }
            }
        }
        out
    }
}
