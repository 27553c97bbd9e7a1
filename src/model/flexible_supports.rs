//! Support flexibility: the abutment does not hold its joints rigidly but
//! gives like a spring of compliance `c` (m/N) in every supported
//! direction.
//!
//! # How it is modelled
//! Every supported degree of freedom becomes free and is held instead by a
//! *support bar*: a strut of axial stiffness `1/c` from a new fixed ground
//! node [`SUPPORT_BAR_LENGTH_M`] away along that axis. So the existing
//! solvers (DR, Newton, the tangent) need nothing new.
//!
//! A support that is also a continuous cable's motor node is split in two:
//! the motor (drum) stays where it is, fixed, because the drums sit on the
//! foundation; a new *bearing* node at the same place takes over the
//! members, the mass and the load, and it is the bearing that gives. The
//! cable still runs from the drum to its first joint.
//!
//! The bars are preloaded with the support reactions of the as-built
//! geometry, so the as-built state stays in equilibrium where it was
//! designed (the abutment was shimmed to the design geometry when the bridge
//! was assembled): only *changes* in the reactions move the supports, by
//! `c·ΔR`. A compliance of zero leaves the structure as it is.
//!
//! # Approximation
//! A bar carrying the reaction `R` adds a geometric stiffness `R/L`
//! across its axis. With `L` = 10 m and reactions of a few hundred newtons
//! that is a few tens of N/m, under 0.2 % of the plausible support stiffness
//! (20 to 100 kN/m).

use nalgebra::Vector3;

use super::structure::{Member, MemberKind, Node, Structure, StructureError};

/// Length of a support bar, m (see the module notes on its geometric
/// stiffness).
pub const SUPPORT_BAR_LENGTH_M: f64 = 10.0;

/// The structure with every support made elastic with compliance
/// `compliance_m_per_n` (> 0; zero returns the structure unchanged).
///
/// Nodes and members keep their indices; bearing nodes, ground nodes and
/// support bars are appended, named `<node>~bearing`, `<node>~ground_<axis>`
/// and `<node>~support_<axis>`.
pub fn with_flexible_supports(
    structure: &Structure,
    compliance_m_per_n: f64,
) -> Result<Structure, StructureError> {
    if compliance_m_per_n == 0.0 {
        return Ok(structure.clone());
    }
    let stiffness_n_per_m = 1.0 / compliance_m_per_n;
    let motor_nodes: Vec<usize> = structure
        .continuous_cables
        .iter()
        .map(|c| c.path[0])
        .collect();
    let reactions = as_built_reactions_n(structure);
    let mut nodes = structure.nodes.clone();
    let mut members = structure.members.clone();
    for (i, node) in structure.nodes.iter().enumerate() {
        if !node.fixed.iter().any(|f| *f) {
            continue;
        }
        let attached: Vec<usize> = members
            .iter()
            .enumerate()
            .filter(|(_, m)| m.nodes.contains(&i))
            .map(|(k, _)| k)
            .collect();
        if attached.is_empty() {
            // Holds nothing but cable drums: nothing to give.
            continue;
        }
        // The node that gives: a new bearing if the drums must stay put.
        let giving = if motor_nodes.contains(&i) {
            nodes.push(Node {
                id: format!("{}~bearing", node.id),
                position_m: node.position_m,
                mass_kg: node.mass_kg,
                fixed: [false; 3],
                load_n: node.load_n,
            });
            let bearing = nodes.len() - 1;
            nodes[i].mass_kg = 0.0;
            nodes[i].load_n = Vector3::zeros();
            for k in attached {
                for end in &mut members[k].nodes {
                    if *end == i {
                        *end = bearing;
                    }
                }
            }
            bearing
        } else {
            nodes[i].fixed = [false; 3];
            i
        };
        for (axis, name) in ["x", "y", "z"].into_iter().enumerate() {
            if !node.fixed[axis] {
                continue;
            }
            let direction = Vector3::ith(axis, 1.0);
            nodes.push(Node {
                id: format!("{}~ground_{name}", node.id),
                position_m: node.position_m - SUPPORT_BAR_LENGTH_M * direction,
                mass_kg: 0.0,
                fixed: [true; 3],
                load_n: Vector3::zeros(),
            });
            // The bar pulls the node towards the ground node with its
            // tension T, so it supplies the reaction component R = −T.
            let tension_n = -reactions[i][axis];
            let rest_length_m = SUPPORT_BAR_LENGTH_M - tension_n / stiffness_n_per_m;
            members.push(Member {
                id: format!("{}~support_{name}", node.id),
                kind: MemberKind::Strut {
                    ea_n: stiffness_n_per_m * rest_length_m,
                    // A support bar stands for a bearing, not a slender
                    // tube: it does not buckle.
                    ei_nm2: 1e12,
                },
                nodes: [nodes.len() - 1, giving],
                rest_length_m,
            });
        }
    }
    Structure::new(
        structure.name.clone(),
        nodes,
        members,
        structure.continuous_cables.clone(),
        structure.gravity_m_per_s2,
        structure.midspan_pairs.clone(),
    )
}

/// Whether the node named `id` is one [`with_flexible_supports`] appended
/// (a bearing or a ground node), not a node of the bridge itself.
pub fn is_support_node(id: &str) -> bool {
    id.ends_with("~bearing") || id.contains("~ground_")
}

/// The reaction the supports give each node's fixed DOFs in the as-built
/// geometry, from the members only (the drums take the continuous cables'
/// pull), N.
fn as_built_reactions_n(structure: &Structure) -> Vec<Vector3<f64>> {
    let x = structure.reference_positions();
    let mut net: Vec<Vector3<f64>> = structure
        .nodes
        .iter()
        .map(|n| n.mass_kg * structure.gravity_m_per_s2 + n.load_n)
        .collect();
    for m in &structure.members {
        let [a, b] = m.nodes;
        let d = x[b] - x[a];
        let length = d.norm();
        let mut tension = m.kind.axial_stiffness(m.rest_length_m) * (length - m.rest_length_m);
        if m.kind.is_tension_only() {
            tension = tension.max(0.0);
        }
        let f = tension * d / length;
        net[a] += f;
        net[b] -= f;
    }
    net.iter().map(|f| -f).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{reference_bridge, BridgeParameters};
    use crate::model::{ForwardModel, JointFriction};
    use crate::model::{RelaxSettings, Workspace};

    fn bridge() -> Structure {
        reference_bridge(&BridgeParameters::default()).unwrap()
    }

    #[test]
    fn zero_compliance_leaves_the_structure_alone() {
        let s = bridge();
        assert_eq!(with_flexible_supports(&s, 0.0).unwrap(), s);
    }

    #[test]
    fn the_as_built_state_stays_in_equilibrium() {
        let s = bridge();
        let f = with_flexible_supports(&s, 2e-5).unwrap();
        assert_eq!(f.nodes[..s.nodes.len()].len(), s.nodes.len());
        let model =
            ForwardModel::new(f, JointFriction::frictionless(), RelaxSettings::default()).unwrap();
        let mut state = model.reference_state();
        let r = model.relax(&mut state, &mut Workspace::default());
        assert!(r.status.is_converged());
        // The preload holds the design geometry: the supports move by
        // far less than the 1 mm a position sensor resolves.
        let moved = state
            .positions_m
            .iter()
            .zip(model.structure.reference_positions())
            .map(|(a, b)| (a - b).norm())
            .fold(0.0, f64::max);
        assert!(moved < 1e-6, "moved {moved} m");
    }

    #[test]
    fn a_support_gives_by_compliance_times_the_load() {
        // One node on a flexible support, loaded by 100 N downwards through
        // a vertical cable from a fixed anchor above: it moves c·100 N.
        let node = |id: &str, z: f64, fixed: bool| Node {
            id: id.into(),
            position_m: Vector3::new(0.0, 0.0, z),
            mass_kg: 0.0,
            fixed: [fixed; 3],
            load_n: Vector3::zeros(),
        };
        let mut loaded = node("support", 0.0, true);
        loaded.load_n = Vector3::new(0.0, 0.0, -100.0);
        let s = Structure::new(
            "test",
            vec![loaded, node("anchor", 1.0, true)],
            vec![Member {
                id: "hanger".into(),
                kind: MemberKind::Cable { ea_n: 1e5 },
                nodes: [0, 1],
                rest_length_m: 1.0,
            }],
            vec![],
            Vector3::zeros(),
            vec![],
        )
        .unwrap();
        let c = 3e-5;
        let f = with_flexible_supports(&s, c).unwrap();
        let model =
            ForwardModel::new(f, JointFriction::frictionless(), RelaxSettings::default()).unwrap();
        let mut state = model.reference_state();
        let r = model.relax(&mut state, &mut Workspace::default());
        assert!(r.status.is_converged());
        // Preloaded with the as-built reaction (+100 N up): no motion.
        assert!(state.positions_m[0].norm() < 1e-9);
        // The anchor is a support too, so it gives as well. An extra 100 N
        // downwards is resisted by the node's own support (1/c) side by side
        // with the hanger (1e5 N/m) in series with the anchor's support.
        let mut m2 = model.structure.clone();
        m2.nodes[0].load_n.z = -200.0;
        let model2 =
            ForwardModel::new(m2, JointFriction::frictionless(), RelaxSettings::default()).unwrap();
        let mut state2 = model2.reference_state();
        assert!(model2
            .relax(&mut state2, &mut Workspace::default())
            .status
            .is_converged());
        let want = -100.0 / (1.0 / c + 1.0 / (1e-5 + c));
        let got = state2.positions_m[0].z;
        assert!((got - want).abs() < 1e-3 * want.abs(), "{got} vs {want}");
    }
}
