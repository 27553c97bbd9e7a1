//! Honest diagnosis of effects local to one member, one motor or one
//! sensor: a load cell reading with a gain error, a position sensor that
//! drifts over the log, one spring softer than designed, one continuous
//! cable softer than designed, one drum zeroed off. The overall RMS
//! dilutes each (one sensor of 34); the local candidates of the second
//! tier must name the right one, with its parameter near the truth. A
//! fault no candidate holds (a load cell that clips) must be located at
//! its sensor, never called "nothing missing" nor a confident effect.
//!
//! Two faults of the log rather than the bridge: rare spikes must be
//! named as outliers and set aside, and a slow trend over the log
//! (creep-like) must be seen as a trend, against the log's clock.
//!
//! One noise-only lab log (seed 41, the truth = the baseline) is shared;
//! each sensor case edits a copy's readings, as the faulty sensor would
//! have.

mod common;

use std::sync::OnceLock;

use common::fixtures::{reference_structure, standard_lab_log};
use tensegrity_deploy::measure::compare::compare;
use tensegrity_deploy::measure::comparison_verdict::where_it_fails;
use tensegrity_deploy::measure::diagnose::{
    diagnose, Candidate, DiagnoseSettings, Diagnosis, Verdict,
};
use tensegrity_deploy::measure::evidence::{evidence, Subject};
use tensegrity_deploy::measure::lab::DAILY_SWING_K;
use tensegrity_deploy::measure::local::{LocalKind, Term};
use tensegrity_deploy::measure::log::MeasurementLog;
use tensegrity_deploy::model::{Effects, MemberKind, Structure};
use tensegrity_deploy::sim::{Axis, EffectModel, SensorTarget};

fn model(structure: Structure) -> EffectModel {
    EffectModel::for_measurement(structure, Effects::default())
}

fn baseline() -> EffectModel {
    model(reference_structure())
}

/// Four cycles (5, 20, 10, 20 cm in four steps each way), standard sensors.
fn lab_log(truth: &EffectModel, seed: u64) -> MeasurementLog {
    standard_lab_log(truth, seed, DAILY_SWING_K)
}

fn clean_log() -> &'static MeasurementLog {
    static LOG: OnceLock<MeasurementLog> = OnceLock::new();
    LOG.get_or_init(|| lab_log(&baseline(), 41))
}

/// The log with `edit(global step, value)` applied to every reading of
/// sensor `sensor`.
fn faulty(sensor: usize, edit: impl Fn(usize, f64) -> f64) -> MeasurementLog {
    let mut log = clean_log().clone();
    let mut k = 0;
    for cycle in &mut log.cycles {
        for step in &mut cycle.readings {
            step[sensor] = step[sensor].map(|v| edit(k, v));
            k += 1;
        }
    }
    log
}

/// Diagnoses `log` with `model` and checks that the first thing found is
/// `term`, named `name`, with its parameter `index` within three standard
/// errors of `truth`, and that the verdict is "missing".
fn found_as(
    model: &EffectModel,
    log: &MeasurementLog,
    term: LocalKind,
    name: &str,
    index: usize,
    truth: f64,
) -> Candidate {
    let d = diagnose(model, log, &DiagnoseSettings::default()).unwrap();
    let Verdict::Missing { found, .. } = &d.verdict else {
        panic!(
            "{name}: expected it found, got {:?}; round 1 ranking {:?}",
            d.verdict,
            d.rounds[0]
                .ranking
                .iter()
                .map(|c| (&c.name, c.held_out_rms, &c.values))
                .collect::<Vec<_>>()
        );
    };
    let c = &found[0];
    let rankings: Vec<Vec<(&String, f64, &Vec<f64>)>> = d
        .rounds
        .iter()
        .map(|r| {
            r.ranking
                .iter()
                .map(|c| (&c.name, c.held_out_rms, &c.values))
                .collect()
        })
        .collect();
    assert_eq!(
        c.term,
        Term::Local(term),
        "found {:?}; rankings {rankings:?}",
        found.iter().map(|c| &c.name).collect::<Vec<_>>()
    );
    assert_eq!(c.name, name);
    let (v, se) = (c.values[index], c.std_errors[index]);
    assert!(
        (v - truth).abs() <= 3.0 * se,
        "{name}: {v} ± {se}, truth {truth}"
    );
    c.clone()
}

fn first_sensor(log: &MeasurementLog, pick: impl Fn(&SensorTarget) -> bool) -> usize {
    log.sensors.iter().position(|s| pick(&s.target)).unwrap()
}

#[test]
fn one_load_cell_with_a_gain_error_is_named() {
    let log = clean_log();
    let cell = first_sensor(log, |t| matches!(t, SensorTarget::SegmentTension { .. }));
    // 4 % gain on a cell reading 60 to 560 N (mean ~250 N): ~10 N, 1.4
    // noise SDs per reading on average, about 8 standard errors in the
    // mean over its 36 readings; the overall RMS moves by ~3 %.
    let name = format!("load_cell_gain({})", log.sensors[cell].id);
    found_as(
        &baseline(),
        &faulty(cell, |_, v| 1.04 * v),
        LocalKind::LoadCellGain { sensor: cell },
        &name,
        0,
        1.04,
    );
}

#[test]
fn a_drifting_position_sensor_is_named() {
    let log = clean_log();
    let z = first_sensor(log, |t| {
        matches!(t, SensorTarget::Position { axis: Axis::Z, .. })
    });
    // 3 mm over the log's 36 readings: three noise SDs at the end, a χ²
    // of about 100 over the log against a penalty of ~23 per half.
    let drift = 0.003 / 35.0;
    let name = format!("position_drift({})", log.sensors[z].id);
    found_as(
        &baseline(),
        &faulty(z, |k, v| v + drift * k as f64),
        LocalKind::PositionDrift { sensor: z },
        &name,
        1,
        drift,
    );
}

#[test]
fn one_soft_spring_is_named_as_that_member() {
    // The first spring of half A at 80 % of its design stiffness: its
    // force, and the geometry around it, change; no library effect scales
    // one member.
    let mut soft = reference_structure();
    let spring = soft
        .members
        .iter()
        .position(|m| matches!(m.kind, MemberKind::Spring { .. }) && m.id.starts_with("A_"))
        .unwrap();
    if let MemberKind::Spring { stiffness_n_per_m } = &mut soft.members[spring].kind {
        *stiffness_n_per_m *= 0.8;
    }
    let id = soft.members[spring].id.clone();
    let log = lab_log(&model(soft), 43);
    found_as(
        &baseline(),
        &log,
        LocalKind::MemberStiffness { member: spring },
        &format!("member_stiffness({id})"),
        0,
        0.8,
    );
}

/// Issue 24, item 5: a continuous cable 40 % softer was blamed, hedged,
/// on its load cell's gain, because no candidate described one continuous
/// cable.
#[test]
fn one_soft_continuous_cable_is_named_as_that_cable() {
    let mut soft = reference_structure();
    let cable = 2;
    soft.continuous_cables[cable].ea_n *= 0.6;
    let id = soft.continuous_cables[cable].id.clone();
    let log = lab_log(&model(soft), 44);
    found_as(
        &baseline(),
        &log,
        LocalKind::CableStiffness { cable },
        &format!("cable_stiffness({id})"),
        0,
        0.6,
    );
}

/// Issue 24, item 5: one drum zeroed 15 mm off (the single truth of
/// issue 22 that slackens a whole continuous cable) is named as that
/// drum's offset, not fitted as a stiffness error that is not there.
#[test]
fn a_drum_zeroed_off_is_named_as_that_drums_offset() {
    let mut long = reference_structure();
    let cable = 6;
    long.continuous_cables[cable].segment_rest_lengths_m[0] += 0.015;
    let id = long.continuous_cables[cable].id.clone();
    let log = lab_log(&model(long), 45);
    found_as(
        &baseline(),
        &log,
        LocalKind::DrumOffset { cable },
        &format!("drum_offset({id})"),
        0,
        0.015,
    );
}

#[test]
fn a_clipping_load_cell_is_located_and_not_called_an_effect() {
    let log = clean_log();
    let cell = first_sensor(log, |t| matches!(t, SensorTarget::SegmentTension { .. }));
    // It reads at most 300 N: no candidate holds a clip. Honest verdicts:
    // a structured residual located at the cell (what was found on the
    // way flagged), or its own gain found without confidence; never
    // "nothing missing", never a confident effect.
    let d: Diagnosis = diagnose(
        &baseline(),
        &faulty(cell, |_, v| v.min(300.0)),
        &DiagnoseSettings::default(),
    )
    .unwrap();
    match &d.verdict {
        Verdict::NothingMissing => panic!("a faulty sensor is not noise"),
        Verdict::Missing { found, confident } => assert!(
            !confident
                && found
                    .iter()
                    .all(|c| c.term == Term::Local(LocalKind::LoadCellGain { sensor: cell })),
            "{:?}",
            d.verdict
        ),
        // Whatever was found on the way must carry its warnings.
        Verdict::Unexplained { found, .. } => {
            assert!(found.iter().all(|c| !c.trusted()), "{found:?}");
            let w = where_it_fails(&d.final_comparison, &d.evidence).unwrap();
            assert_eq!(log.sensors[w.sensor].id, log.sensors[cell].id);
            assert_eq!(
                d.evidence.most_significant_sensor().unwrap().subject,
                Subject::Sensor(cell)
            );
        }
    }
}

#[test]
fn the_shared_log_itself_is_nothing_missing() {
    // The control: the same log unedited passes the per-sensor tests, so
    // the cases above fail because of their fault, not the seed.
    let d = diagnose(&baseline(), clean_log(), &DiagnoseSettings::default()).unwrap();
    assert_eq!(d.verdict, Verdict::NothingMissing);
}

#[test]
fn rare_spikes_are_named_as_outliers_not_structure() {
    // Three spikes of 20 to 30 noise SDs in 1224 readings: a load cell
    // reading 175 N high, one reading 140 N low, a position 25 mm off.
    let mut spiky = clean_log().clone();
    let cell = first_sensor(&spiky, |t| matches!(t, SensorTarget::SegmentTension { .. }));
    let x = first_sensor(&spiky, |t| {
        matches!(t, SensorTarget::Position { axis: Axis::X, .. })
    });
    let spikes = [(1, 3, cell, 175.0), (3, 1, cell, -140.0), (2, 5, x, 0.025)];
    for &(c, k, s, add) in &spikes {
        let v = &mut spiky.cycles[c].readings[k][s];
        *v = v.map(|v| v + add);
    }
    // Taken as they are, they fail the per-sensor tests (the control: the
    // rule, not the seed, makes the verdict below).
    let raw = compare(&baseline(), &spiky).unwrap();
    let noise = DiagnoseSettings::default().noise;
    assert!(evidence(&raw, &spiky.sensors, &noise).any_significant());
    let d = diagnose(&baseline(), &spiky, &DiagnoseSettings::default()).unwrap();
    let mut named: Vec<(usize, usize, usize)> = d
        .outliers
        .iter()
        .map(|o| (o.cycle, o.step, o.sensor))
        .collect();
    named.sort();
    let mut want: Vec<(usize, usize, usize)> = spikes.iter().map(|s| (s.0, s.1, s.2)).collect();
    want.sort();
    assert_eq!(named, want);
    assert_eq!(d.verdict, Verdict::NothingMissing);
}

#[test]
fn a_slow_trend_is_seen_against_the_logs_clock() {
    // Every midspan node sinks 4 mm over the log (creep of the whole
    // bridge), as its ten vertical position sensors read. No candidate
    // holds a creep: honest verdicts are a structured residual or an
    // effect found without confidence; the residual goes with the log's
    // clock (step index or cycle, which rise together), not temperature.
    let mut creeping = clean_log().clone();
    let verticals: Vec<usize> = (0..creeping.sensors.len())
        .filter(|&s| {
            matches!(
                creeping.sensors[s].target,
                SensorTarget::Position { axis: Axis::Z, .. }
            )
        })
        .collect();
    let mut k = 0;
    for cycle in &mut creeping.cycles {
        for step in &mut cycle.readings {
            for &s in &verticals {
                step[s] = step[s].map(|v| v - 0.004 * k as f64 / 35.0);
            }
            k += 1;
        }
    }
    let d = diagnose(&baseline(), &creeping, &DiagnoseSettings::default()).unwrap();
    match &d.verdict {
        Verdict::NothingMissing => panic!("a trend is not noise"),
        Verdict::Missing {
            confident: true,
            found,
        } => panic!(
            "a confident effect for a creep: {:?}",
            found.iter().map(|c| &c.name).collect::<Vec<_>>()
        ),
        _ => {}
    }
    let w = where_it_fails(&d.final_comparison, &d.evidence).unwrap();
    assert!(verticals.contains(&w.sensor), "{w:?}");
    assert!(
        matches!(w.feature.as_deref(), Some("step_index" | "cycle")),
        "{w:?}"
    );
}
