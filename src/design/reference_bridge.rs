//! The reference structure: a 1/4-scale "hollow-rope" tensegrity footbridge
//! in two halves that deploy towards midspan.
//!
//! # Geometry and topology (per half, `n` modules, default 2)
//! Rings `r = 0..=2n` are regular pentagons in planes normal to the bridge
//! axis x, spaced half a module apart; node `k` of ring `r` sits at angle
//! `ψ = −90° + 72°·k + τ·r` in the y–z plane (ring twist `τ`, default 54°).
//! Module `m` spans rings `2m` (end), `2m+1` (middle, radius scaled by
//! `middle_ring_radius_ratio`, default 0.7) and `2m+2` (end); neighbouring
//! modules share an end ring. Ring 0 (abutment) is supported; ring `2n`
//! holds the five midspan nodes.
//!
//! Per module, with node `(r, k)` and the offsets of [`BridgeTopology`]
//! (defaults in brackets):
//! - 15 struts in one circuit: `(2m,k)–(2m+1,k)`, `(2m+1,k)–(2m+2,k+b)` [b=1]
//!   and `(2m+2,k)–(2m,k+q)` [q=4], the long strut back across the module;
//! - 5 axial members `(2m,k)–(2m+2,k+d)` [d=4];
//! - ring members `(r,k)–(r,k+1)`.
//!
//! Springs go either on the interior rings (default; abutment and midspan
//! rings and axial members are cables) or on the axial members and the
//! shared ring. 5 continuous cables per half: cable `k` passes node
//! `(r, k+c·r)` [c=4], i.e. at `−18°` per ring with the defaults, a gentle
//! helix; motor at the abutment, one joint per interior ring, end at a
//! midspan node.
//!
//! # How the topology was chosen
//! Two requirements, both checked by a scan over twist (18/36/54°), middle
//! ring ratio (0.7–1.15), the four offsets and the spring placement:
//! 1. a prestress exists (cables and springs in tension, struts in
//!    compression) in equilibrium with self-weight;
//! 2. it is *stable with frictionless joints*: the tangent stiffness with
//!    every continuous cable sliding freely is positive definite (see
//!    [`super::form_finding::find_stable_prestress`]).
//!
//! The first reference bridge (36° twist, equal ring radii) met (1) but not
//! (2): with sliding joints its middle rings could twist and slide along
//! the cables, and 2 mm of reel-in sent nodes 0.27 m away. No 36° variant
//! in the scan meets (2); the default meets it with a margin of 1054 N/m and
//! folds smoothly when all cables are paid out 40 cm and reeled back.
//!
//! With `n = 2`: 25 nodes, 30 struts, 15 springs, 20 discontinuous cables and
//! 5 continuous cables of 4 segments (55 cable-like members), the seed's
//! counts. The second half is the mirror image of the first in the midspan
//! plane `x = n·module_length`.
//!
//! # Prestress
//! [`super::form_finding`] finds member forces in equilibrium with self-weight
//! in the designed geometry (continuous cables at `continuous_cable_tension_n`,
//! equal in all segments as for frictionless joints), with the stiffness
//! bound `min_stiffness_n_per_m`; rest lengths follow from the forces, so
//! the designed geometry *is* the equilibrium under self-weight.

use nalgebra::Vector3;
use thiserror::Error;

use super::form_finding::{find_stable_prestress, ForceGroup};
use crate::model::structure::{
    ContinuousCable, Member, MemberKind, Node, Structure, StructureError,
};

/// Most modules per half the generator builds: its form finding's memory
/// grows with about the cube of the size (0.9 GB and half a second at 16;
/// at 64 it would pass 7.5 GB). The seed's bridge has 2.
pub const MAX_MODULES_PER_HALF: usize = 16;

/// Every value the generator assumes, with its source or reasoning.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BridgeParameters {
    /// Modules per half. Seed: 2 (a 4 m bridge of four 1 m modules).
    pub modules_per_half: usize,
    /// Module length along the bridge, m. Seed: 4 m over four modules.
    pub module_length_m: f64,
    /// Circumradius of the pentagonal rings, m. Not published; 0.5 m makes a
    /// 1 m "hollow rope", a quarter of a walkable 4 m full-scale section.
    pub ring_radius_m: f64,
    /// Strut outer diameter, m. Seed: 28 mm steel tubes.
    pub strut_outer_diameter_m: f64,
    /// Strut wall thickness, m. Not published; 1.5 mm is a common wall for a
    /// 28 mm structural tube.
    pub strut_wall_m: f64,
    /// Young's modulus of steel, Pa. Standard value.
    pub steel_youngs_modulus_pa: f64,
    /// Density of steel, kg/m³. Standard value.
    pub steel_density_kg_per_m3: f64,
    /// Axial stiffness of the 4 mm braided steel cables, N. Assumed: about
    /// 7 mm² metallic area (a 7×19 rope fills ~55 % of its 12.6 mm² circle)
    /// at a rope modulus of 100 GPa.
    pub cable_ea_n: f64,
    /// Cable mass per length, kg/m. 4 mm steel rope, catalogue value.
    pub cable_mass_kg_per_m: f64,
    /// Ring spring stiffness, N/m. Not published; soft enough that folding
    /// is carried by the springs rather than by stretching steel.
    pub spring_stiffness_n_per_m: f64,
    /// Mass of one spring with its end fittings, kg. Assumed.
    pub spring_mass_kg: f64,
    /// Mass of one joint (node body, cable seats, bolts), kg. Assumed.
    pub joint_mass_kg: f64,
    /// Continuous-cable tension in the deployed state, N. Seed: 400–700 N
    /// measured; the middle of that range.
    pub continuous_cable_tension_n: f64,
    /// Smallest tension allowed in a discontinuous cable, N: keeps them
    /// taut with margin for deployment.
    pub cable_min_tension_n: f64,
    /// Target tension of discontinuous cables, N.
    pub cable_target_tension_n: f64,
    /// Smallest spring tension, N.
    pub spring_min_tension_n: f64,
    /// Target spring tension, N.
    pub spring_target_tension_n: f64,
    /// Smallest strut compression, N.
    pub strut_min_compression_n: f64,
    /// Gravitational acceleration, m/s².
    pub gravity_m_per_s2: f64,
    /// Smallest eigenvalue the deployed state's tangent stiffness must have
    /// with every continuous cable sliding freely (μ = 0), N/m. Form finding
    /// enforces it; it is the margin against the prestress-stabilised
    /// mechanisms of the clustered cables. Must be positive for the
    /// frictionless model to be stable; `-inf` drops the requirement (for
    /// structures built only to time the solver). Default 300 N/m; the
    /// default bridge reaches 1054 N/m without any cut.
    pub min_stiffness_n_per_m: f64,
    /// Which nodes members connect.
    pub topology: BridgeTopology,
}

/// Where the 15 springs of a half go.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SpringPlacement {
    /// Ring members of the interior rings are springs; the abutment and
    /// midspan rings and the axial members are cables.
    InteriorRings,
    /// Axial members and the shared ring are springs; the other interior
    /// rings and the midspan ring are cables (the abutment ring, whose nodes
    /// are all supported, has none).
    AxialAndSharedRing,
}

/// Node connectivity of a module, as offsets in the ring index `k`
/// (node `(r, k)` is node `k mod 5` of ring `r`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct BridgeTopology {
    /// Rotation of each ring from the previous one, degrees.
    pub ring_twist_deg: f64,
    /// Middle-ring circumradius over `ring_radius_m`.
    pub middle_ring_radius_ratio: f64,
    /// Second short strut: `(2m+1, k)–(2m+2, k + offset)`.
    pub second_strut_offset: usize,
    /// Long strut: `(2m+2, k)–(2m, k + offset)`.
    pub long_strut_offset: usize,
    /// Axial member: `(2m, k)–(2m+2, k + offset)`.
    pub axial_offset: usize,
    /// Continuous cable `k` passes node `(r, k + offset·r)`.
    pub cable_ring_offset: usize,
    /// Where the springs go.
    pub springs: SpringPlacement,
}

impl Default for BridgeTopology {
    fn default() -> Self {
        BridgeTopology {
            ring_twist_deg: 54.0,
            middle_ring_radius_ratio: 0.7,
            second_strut_offset: 1,
            long_strut_offset: 4,
            axial_offset: 4,
            cable_ring_offset: 4,
            springs: SpringPlacement::InteriorRings,
        }
    }
}

impl Default for BridgeParameters {
    fn default() -> Self {
        BridgeParameters {
            modules_per_half: 2,
            module_length_m: 1.0,
            ring_radius_m: 0.5,
            strut_outer_diameter_m: 0.028,
            strut_wall_m: 0.0015,
            steel_youngs_modulus_pa: 210e9,
            steel_density_kg_per_m3: 7850.0,
            cable_ea_n: 7.0e5,
            cable_mass_kg_per_m: 0.065,
            spring_stiffness_n_per_m: 4000.0,
            spring_mass_kg: 0.25,
            joint_mass_kg: 0.35,
            continuous_cable_tension_n: 550.0,
            cable_min_tension_n: 100.0,
            cable_target_tension_n: 300.0,
            spring_min_tension_n: 50.0,
            spring_target_tension_n: 200.0,
            strut_min_compression_n: 10.0,
            gravity_m_per_s2: 9.81,
            min_stiffness_n_per_m: 300.0,
            topology: BridgeTopology::default(),
        }
    }
}

impl BridgeParameters {
    /// Strut cross-section area, m².
    pub fn strut_area_m2(&self) -> f64 {
        let (d, t) = (self.strut_outer_diameter_m, self.strut_wall_m);
        std::f64::consts::PI * (d * t - t * t)
    }

    /// Strut second moment of area, m⁴.
    pub fn strut_inertia_m4(&self) -> f64 {
        let d = self.strut_outer_diameter_m;
        let di = d - 2.0 * self.strut_wall_m;
        std::f64::consts::PI / 64.0 * (d.powi(4) - di.powi(4))
    }

    /// Total bridge length, m.
    pub fn bridge_length_m(&self) -> f64 {
        2.0 * self.modules_per_half as f64 * self.module_length_m
    }
}

/// Why a bridge could not be generated.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum BridgeError {
    /// A parameter is out of range.
    #[error("bridge parameter `{field}`: {reason}")]
    BadParameter {
        /// The parameter.
        field: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// No prestress meets the bounds in this geometry.
    #[error("form finding found no admissible prestress (QP status {0:?}); change ring radius, module length or tension bounds")]
    NoPrestress(crate::numerics::qp::QpStatus),
    /// Prestress exists but none makes the frictionless structure as stiff
    /// as asked.
    #[error("no prestress gives a tangent stiffness above {wanted_n_per_m} N/m with sliding joints (best found {achieved_n_per_m:.1} N/m); lower `min_stiffness_n_per_m` or change the geometry")]
    Unstable {
        /// Smallest eigenvalue reached, N/m.
        achieved_n_per_m: f64,
        /// `min_stiffness_n_per_m`.
        wanted_n_per_m: f64,
    },
    /// The QP solver could not be set up.
    #[error(transparent)]
    Qp(#[from] crate::numerics::qp::QpError),
    /// The generated structure failed validation (a generator bug).
    #[error(transparent)]
    Structure(#[from] StructureError),
}

const SIDES: usize = 5;
/// Cutting-plane rounds allowed to reach the stiffness bound.
const STABILITY_ROUNDS: usize = 60;

#[derive(Clone, Copy, PartialEq)]
enum Kind {
    Strut,
    Cable,
    Spring,
}

/// Builds the reference bridge: both halves, form-found under self-weight.
pub fn reference_bridge(p: &BridgeParameters) -> Result<Structure, BridgeError> {
    check(p)?;
    let n = p.modules_per_half;
    let rings = 2 * n + 1;
    let half_nodes = rings * SIDES;
    let idx = |r: usize, k: usize| r * SIDES + k % SIDES;

    // One half's geometry and topology.
    let mut x = Vec::with_capacity(half_nodes);
    for r in 0..rings {
        for k in 0..SIDES {
            let psi = (-90.0 + 72.0 * k as f64 + p.topology.ring_twist_deg * r as f64).to_radians();
            let radius = if r % 2 == 1 {
                p.ring_radius_m * p.topology.middle_ring_radius_ratio
            } else {
                p.ring_radius_m
            };
            x.push(Vector3::new(
                0.5 * p.module_length_m * r as f64,
                radius * psi.cos(),
                radius * psi.sin(),
            ));
        }
    }
    let t = &p.topology;
    let mut members: Vec<(Kind, [usize; 2], String)> = Vec::new();
    let axial_kind = match t.springs {
        SpringPlacement::InteriorRings => Kind::Cable,
        SpringPlacement::AxialAndSharedRing => Kind::Spring,
    };
    for m in 0..n {
        let (e0, mid, e1) = (2 * m, 2 * m + 1, 2 * m + 2);
        for k in 0..SIDES {
            members.push((
                Kind::Strut,
                [idx(e0, k), idx(mid, k)],
                format!("strut_m{m}_a{k}"),
            ));
            members.push((
                Kind::Strut,
                [idx(mid, k), idx(e1, k + t.second_strut_offset)],
                format!("strut_m{m}_b{k}"),
            ));
            members.push((
                Kind::Strut,
                [idx(e1, k), idx(e0, k + t.long_strut_offset)],
                format!("strut_m{m}_long{k}"),
            ));
            members.push((
                axial_kind,
                [idx(e0, k), idx(e1, k + t.axial_offset)],
                format!("axial_m{m}_{k}"),
            ));
        }
    }
    for r in 0..rings {
        let kind = match t.springs {
            SpringPlacement::InteriorRings if r == 0 || r == rings - 1 => Kind::Cable,
            SpringPlacement::InteriorRings => Kind::Spring,
            SpringPlacement::AxialAndSharedRing if r == 2 => Kind::Spring,
            SpringPlacement::AxialAndSharedRing => Kind::Cable,
        };
        if kind == Kind::Cable && r == 0 && t.springs == SpringPlacement::AxialAndSharedRing {
            continue;
        }
        for k in 0..SIDES {
            members.push((kind, [idx(r, k), idx(r, k + 1)], format!("ring{r}_{k}")));
        }
    }
    let paths: Vec<Vec<usize>> = (0..SIDES)
        .map(|k| {
            (0..rings)
                .map(|r| idx(r, k + t.cable_ring_offset * r))
                .collect()
        })
        .collect();
    let fixed: Vec<[bool; 3]> = (0..half_nodes).map(|i| [i < SIDES; 3]).collect();

    // Lumped masses: joint plus half of every attached member.
    let strut_kg_per_m = p.strut_area_m2() * p.steel_density_kg_per_m3;
    let len = |[a, b]: [usize; 2]| (x[b] - x[a]).norm();
    let mut mass = vec![p.joint_mass_kg; half_nodes];
    for (kind, ends, _) in &members {
        let kg = match kind {
            Kind::Strut => strut_kg_per_m * len(*ends),
            Kind::Cable => p.cable_mass_kg_per_m * len(*ends),
            Kind::Spring => p.spring_mass_kg,
        };
        mass[ends[0]] += 0.5 * kg;
        mass[ends[1]] += 0.5 * kg;
    }
    for path in &paths {
        for w in path.windows(2) {
            let kg = p.cable_mass_kg_per_m * len([w[0], w[1]]);
            mass[w[0]] += 0.5 * kg;
            mass[w[1]] += 0.5 * kg;
        }
    }
    let g = Vector3::new(0.0, 0.0, -p.gravity_m_per_s2);
    let loads: Vec<Vector3<f64>> = mass.iter().map(|m| *m * g).collect();

    // Prestress in equilibrium with self-weight.
    let ea_strut = p.steel_youngs_modulus_pa * p.strut_area_m2();
    let ei_strut = p.steel_youngs_modulus_pa * p.strut_inertia_m4();
    let scale = p.continuous_cable_tension_n;
    let mut groups: Vec<ForceGroup> = members
        .iter()
        .map(|(kind, ends, _)| {
            let (min_n, max_n, target_n, weight) = match kind {
                Kind::Strut => (-1e5, -p.strut_min_compression_n, 0.0, 1e-2),
                Kind::Cable => (p.cable_min_tension_n, 1e5, p.cable_target_tension_n, 1.0),
                // A spring's rest length must stay positive: cap its
                // tension at 80 % of k·L (rest length ≥ 20 % of its length).
                Kind::Spring => (
                    p.spring_min_tension_n,
                    0.8 * p.spring_stiffness_n_per_m * len(*ends),
                    p.spring_target_tension_n,
                    1.0,
                ),
            };
            let axial_stiffness_n_per_m = match kind {
                Kind::Strut => ea_strut / len(*ends),
                Kind::Cable => p.cable_ea_n / len(*ends),
                Kind::Spring => p.spring_stiffness_n_per_m,
            };
            ForceGroup {
                elements: vec![*ends],
                min_n,
                max_n,
                target_n,
                weight: weight / (scale * scale),
                axial_stiffness_n_per_m,
            }
        })
        .collect();
    for path in &paths {
        let total: f64 = path.windows(2).map(|w| len([w[0], w[1]])).sum();
        groups.push(ForceGroup {
            elements: path.windows(2).map(|w| [w[0], w[1]]).collect(),
            min_n: p.continuous_cable_tension_n,
            max_n: p.continuous_cable_tension_n,
            target_n: p.continuous_cable_tension_n,
            weight: 1.0 / (scale * scale),
            axial_stiffness_n_per_m: p.cable_ea_n / total,
        });
    }
    let found = find_stable_prestress(
        &x,
        &fixed,
        &loads,
        &groups,
        p.min_stiffness_n_per_m,
        STABILITY_ROUNDS,
    )?;
    if !found.solution.status.is_solved() {
        return Err(BridgeError::NoPrestress(found.solution.status));
    }
    if !found.is_stable(p.min_stiffness_n_per_m) {
        return Err(BridgeError::Unstable {
            achieved_n_per_m: found.min_eigenvalue_n_per_m,
            wanted_n_per_m: p.min_stiffness_n_per_m,
        });
    }
    let force = &found.solution.x;

    // Rest lengths from forces: the designed geometry is the equilibrium.
    let make_member =
        |(kind, ends, id): &(Kind, [usize; 2], String), t: f64, offset: usize, prefix: &str| {
            let l = len(*ends);
            let (kind, rest) = match kind {
                Kind::Strut => (
                    MemberKind::Strut {
                        ea_n: ea_strut,
                        ei_nm2: ei_strut,
                    },
                    l * ea_strut / (ea_strut + t),
                ),
                Kind::Cable => (
                    MemberKind::Cable { ea_n: p.cable_ea_n },
                    l * p.cable_ea_n / (p.cable_ea_n + t),
                ),
                Kind::Spring => (
                    MemberKind::Spring {
                        stiffness_n_per_m: p.spring_stiffness_n_per_m,
                    },
                    l - t / p.spring_stiffness_n_per_m,
                ),
            };
            Member {
                id: format!("{prefix}_{id}"),
                kind,
                nodes: [ends[0] + offset, ends[1] + offset],
                rest_length_m: rest,
            }
        };

    let total_length = p.bridge_length_m();
    let mut nodes = Vec::with_capacity(2 * half_nodes);
    let mut all_members = Vec::with_capacity(2 * members.len());
    let mut cables = Vec::with_capacity(2 * SIDES);
    for (h, prefix) in ["A", "B"].iter().enumerate() {
        let offset = h * half_nodes;
        for (i, xi) in x.iter().enumerate() {
            let position = if h == 0 {
                *xi
            } else {
                Vector3::new(total_length - xi.x, xi.y, xi.z)
            };
            nodes.push(Node {
                id: format!("{prefix}{}_{}", i / SIDES, i % SIDES),
                position_m: position,
                mass_kg: mass[i],
                fixed: fixed[i],
                load_n: Vector3::zeros(),
            });
        }
        for (m, t) in members.iter().zip(force.iter()) {
            all_members.push(make_member(m, *t, offset, prefix));
        }
        for (k, path) in paths.iter().enumerate() {
            let t = force[members.len() + k];
            let rest = path
                .windows(2)
                .map(|w| len([w[0], w[1]]) * p.cable_ea_n / (p.cable_ea_n + t))
                .collect();
            cables.push(ContinuousCable {
                id: format!("{prefix}_cc{k}"),
                path: path.iter().map(|i| i + offset).collect(),
                ea_n: p.cable_ea_n,
                segment_rest_lengths_m: rest,
            });
        }
    }
    // Grouped by kind, as structure files list them, so a written and
    // re-read bridge has the same member order.
    all_members.sort_by_key(|m| match m.kind {
        MemberKind::Strut { .. } => 0,
        MemberKind::Cable { .. } => 1,
        MemberKind::Spring { .. } => 2,
    });
    let last_ring = rings - 1;
    let midspan_pairs = (0..SIDES)
        .map(|k| [idx(last_ring, k), half_nodes + idx(last_ring, k)])
        .collect();
    Ok(Structure::new(
        format!("hollow-rope tensegrity footbridge, {n} modules per half"),
        nodes,
        all_members,
        cables,
        g,
        midspan_pairs,
    )?)
}

fn check(p: &BridgeParameters) -> Result<(), BridgeError> {
    let positive = |field: &'static str, v: f64| {
        if v.is_finite() && v > 0.0 {
            Ok(())
        } else {
            Err(BridgeError::BadParameter {
                field,
                reason: format!("must be a positive number, got {v}"),
            })
        }
    };
    if p.modules_per_half == 0 || p.modules_per_half > MAX_MODULES_PER_HALF {
        return Err(BridgeError::BadParameter {
            field: "modules_per_half",
            reason: format!(
                "must be 1 to {MAX_MODULES_PER_HALF} (the limit on the bridge's size), got {}",
                p.modules_per_half
            ),
        });
    }
    positive("module_length_m", p.module_length_m)?;
    positive("ring_radius_m", p.ring_radius_m)?;
    positive("strut_outer_diameter_m", p.strut_outer_diameter_m)?;
    positive("strut_wall_m", p.strut_wall_m)?;
    if p.strut_wall_m * 2.0 >= p.strut_outer_diameter_m {
        return Err(BridgeError::BadParameter {
            field: "strut_wall_m",
            reason: "must be less than half the outer diameter".into(),
        });
    }
    positive("steel_youngs_modulus_pa", p.steel_youngs_modulus_pa)?;
    positive("steel_density_kg_per_m3", p.steel_density_kg_per_m3)?;
    positive("cable_ea_n", p.cable_ea_n)?;
    positive("cable_mass_kg_per_m", p.cable_mass_kg_per_m)?;
    positive("spring_stiffness_n_per_m", p.spring_stiffness_n_per_m)?;
    positive("spring_mass_kg", p.spring_mass_kg)?;
    positive("joint_mass_kg", p.joint_mass_kg)?;
    positive("continuous_cable_tension_n", p.continuous_cable_tension_n)?;
    positive("gravity_m_per_s2", p.gravity_m_per_s2)?;
    let non_negative = |field: &'static str, v: f64| {
        if v.is_finite() && v >= 0.0 {
            Ok(())
        } else {
            Err(BridgeError::BadParameter {
                field,
                reason: format!("must be a non-negative number, got {v}"),
            })
        }
    };
    non_negative("cable_min_tension_n", p.cable_min_tension_n)?;
    non_negative("cable_target_tension_n", p.cable_target_tension_n)?;
    non_negative("spring_min_tension_n", p.spring_min_tension_n)?;
    non_negative("spring_target_tension_n", p.spring_target_tension_n)?;
    non_negative("strut_min_compression_n", p.strut_min_compression_n)?;
    positive(
        "topology.middle_ring_radius_ratio",
        p.topology.middle_ring_radius_ratio,
    )?;
    if !p.topology.ring_twist_deg.is_finite() {
        return Err(BridgeError::BadParameter {
            field: "topology.ring_twist_deg",
            reason: format!("must be a finite number, got {}", p.topology.ring_twist_deg),
        });
    }
    if p.min_stiffness_n_per_m.is_nan() {
        return Err(BridgeError::BadParameter {
            field: "min_stiffness_n_per_m",
            reason: "must be a number".into(),
        });
    }
    Ok(())
}
