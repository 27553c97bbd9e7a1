//! Diagnosis on data with a hidden effect: logs made by the synthetic lab on
//! a truth the diagnosing model does not know, as the issue "Compare the
//! model with measurements, find the missing physical effect" asks.
//!
//! Logs are kept small for speed: four cycles of
//! [`common::fixtures::LAB_AMPLITUDES_M`] in [`common::fixtures::LAB_STEPS`]
//! steps each way (alternate cycles fitted and held out, so both
//! halves see a 20 cm cycle), the standard sensors (four load cells at 7 N,
//! the ten midspan nodes in 3-D at 1 mm, a temperature channel at 0.1 °C,
//! swinging 20 ± 12 °C).

mod common;

use rand::{Rng, SeedableRng};

use common::fixtures::{reference_structure, standard_lab_log};
use tensegrity_deploy::measure::diagnose::{diagnose, DiagnoseSettings, ParameterFlag, Verdict};
use tensegrity_deploy::measure::lab::DAILY_SWING_K;
use tensegrity_deploy::measure::local::Term;
use tensegrity_deploy::measure::log::MeasurementLog;
use tensegrity_deploy::model::{EffectKind, Effects, MemberKind, Structure};
use tensegrity_deploy::sim::EffectModel;

/// Thermal length change is the weakest effect: over the standard 12 K swing
/// it moves the midspan nodes by 0.3 mm at most, a third of the position
/// noise, and a small log cannot show it. Its test logs a 25 K swing (an
/// outdoor rig in sun, or tests across seasons), where it moves them by
/// 0.6 mm.
const THERMAL_SWING_K: f64 = 25.0;

fn model(structure: Structure, effects: Effects) -> EffectModel {
    EffectModel::for_measurement(structure, effects)
}

fn lab_log(truth: &EffectModel, seed: u64) -> MeasurementLog {
    let swing_k = if truth.effects.thermal.is_some() {
        THERMAL_SWING_K
    } else {
        DAILY_SWING_K
    };
    standard_lab_log(truth, seed, swing_k)
}

/// Parameters drawn uniformly from the effect's plausible range.
fn plausible_draw(kind: EffectKind, seed: u64) -> Vec<f64> {
    let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
    kind.parameters()
        .iter()
        .map(|p| rng.gen_range(p.plausible.0..=p.plausible.1))
        .collect()
}

/// Hide `kind` at a plausible value, diagnose with the baseline model: the
/// effect ranks first, brings the held-out RMS within 1.5 noise SDs, and
/// every parameter comes back within 10 % or three standard errors.
fn hidden_effect_is_found(kind: EffectKind, seed: u64) {
    hidden_values_are_found(kind, plausible_draw(kind, seed), seed);
}

/// [`hidden_effect_is_found`] at the given parameter values.
fn hidden_values_are_found(kind: EffectKind, truth_values: Vec<f64>, seed: u64) {
    let truth = model(
        reference_structure(),
        Effects::default().with_parameters(kind, &truth_values),
    );
    let log = lab_log(&truth, seed);
    let baseline = model(reference_structure(), Effects::default());
    let settings = DiagnoseSettings {
        max_rounds: 1,
        ..DiagnoseSettings::default()
    };
    let d = diagnose(&baseline, &log, &settings).unwrap();
    let round = &d.rounds[0];
    let best = &round.ranking[0];
    assert_eq!(
        best.term,
        Term::Global(kind),
        "truth {truth_values:?}; ranking {:?}",
        round
            .ranking
            .iter()
            .map(|c| (c.name.clone(), c.held_out_rms))
            .collect::<Vec<_>>()
    );
    assert!(
        best.held_out_rms <= settings.explained_rms,
        "held-out RMS {} σ (model without it: {} σ)",
        best.held_out_rms,
        round.base_held_out_rms
    );
    for ((spec, fit), (se, truth)) in kind
        .parameters()
        .iter()
        .zip(&best.values)
        .zip(best.std_errors.iter().zip(&truth_values))
    {
        let error = (fit - truth).abs();
        assert!(
            error <= 0.1 * truth.abs() || error <= 3.0 * se,
            "{}.{}: fitted {fit} ± {se}, truth {truth}",
            kind.name(),
            spec.name
        );
    }
    assert!(
        matches!(&d.verdict, Verdict::Missing { found, confident: true } if found.len() == 1 && found[0].term == Term::Global(kind)),
        "{:?}",
        d.verdict
    );
}

macro_rules! hidden_effect_tests {
    ($($name:ident: $kind:expr, $seed:expr;)*) => {$(
        #[test]
        fn $name() {
            hidden_effect_is_found($kind, $seed);
        }
    )*};
}

hidden_effect_tests! {
    hidden_joint_friction_is_found: EffectKind::JointFriction, 11;
    hidden_motor_slip_and_backlash_is_found: EffectKind::Motor, 12;
    hidden_stiffness_error_is_found: EffectKind::StiffnessError, 13;
    hidden_thermal_length_change_is_found: EffectKind::Thermal, 14;
    hidden_joint_mass_error_is_found: EffectKind::JointMassError, 15;
    hidden_load_cell_bias_is_found: EffectKind::LoadCellBias, 16;
    hidden_joint_eccentricity_is_found: EffectKind::JointEccentricity, 17;
    hidden_support_flexibility_is_found: EffectKind::SupportFlexibility, 18;
}

/// Review of the diagnose speed work (issue 24): ending the search once
/// the model passed the noise tests lost a real second effect. The noise
/// limit leaves up to about 4·√(2n) of held-out χ² unexplained, while a
/// candidate is accepted for a gain above its penalty (about 11), so
/// friction alone left this log "clean" and the 5 % joint-mass error
/// under it was never searched for (seed 22: its second-round held-out
/// gain is 12.8 against a penalty of 10.6). Every round runs.
#[test]
fn a_second_effect_under_the_noise_limit_is_still_found() {
    let truth = model(
        reference_structure(),
        Effects::default()
            .with_parameters(EffectKind::JointFriction, &[0.15])
            .with_parameters(EffectKind::JointMassError, &[1.05]),
    );
    let log = lab_log(&truth, 22);
    let baseline = model(reference_structure(), Effects::default());
    let d = diagnose(&baseline, &log, &DiagnoseSettings::default()).unwrap();
    let found: Vec<Term> = match &d.verdict {
        Verdict::Missing { found, .. } | Verdict::Unexplained { found, .. } => {
            found.iter().map(|c| c.term).collect()
        }
        Verdict::NothingMissing => vec![],
    };
    assert!(
        found.contains(&Term::Global(EffectKind::JointFriction))
            && found.contains(&Term::Global(EffectKind::JointMassError)),
        "{:?}",
        d.verdict
    );
}

/// Issue 24: a drum that slips without backlash (slip 3 %, backlash 0)
/// was found, but "not confident" only because the fitted backlash sat at
/// its search bound 0, its true value and the end of its admissible range.
/// Found, and confident.
#[test]
fn a_slipping_drum_without_backlash_is_found_confidently() {
    hidden_values_are_found(EffectKind::Motor, vec![0.03, 0.0], 19);
}

#[test]
fn the_library_has_a_hidden_effect_test_for_every_effect() {
    // The macro list above must grow with the library.
    assert_eq!(EffectKind::ALL.len(), 8);
}

/// With nothing hidden, the verdict is "nothing missing" on at least 19 of
/// 20 noise seeds (the noise limit is four sampling SDs, so a false alarm
/// should be rarer than 1 in 10 000).
#[test]
fn nothing_hidden_is_nothing_missing_on_19_of_20_seeds() {
    let baseline = model(reference_structure(), Effects::default());
    let mut clean = 0;
    for seed in 100..120 {
        let log = lab_log(&baseline, seed);
        let d = diagnose(&baseline, &log, &DiagnoseSettings::default()).unwrap();
        if d.verdict == Verdict::NothingMissing {
            clean += 1;
        }
    }
    eprintln!("nothing missing on {clean} of 20 seeds");
    assert!(clean >= 19, "nothing missing on {clean} of 20 seeds");
}

/// Diagnoses `log` on the baseline model: the verdict must be the two
/// library effects `kinds` (in `EffectKind` order) missing. Returns the
/// diagnosis and the candidates found.
fn two_found(
    log: &MeasurementLog,
    kinds: [EffectKind; 2],
) -> (
    tensegrity_deploy::measure::diagnose::Diagnosis,
    Vec<tensegrity_deploy::measure::diagnose::Candidate>,
) {
    let d = diagnose(
        &model(reference_structure(), Effects::default()),
        log,
        &DiagnoseSettings::default(),
    )
    .unwrap();
    let Verdict::Missing { found, .. } = &d.verdict else {
        panic!("{:?}", d.verdict);
    };
    let found = found.clone();
    let mut terms: Vec<_> = found.iter().map(|c| c.term).collect();
    terms.sort();
    assert_eq!(terms, kinds.map(Term::Global).to_vec());
    (d, found)
}

/// Friction plus support flexibility: both are found, one per round, and
/// their joint refit puts both parameters within three joint standard
/// errors of the truth.
#[test]
fn two_hidden_effects_are_found_in_two_rounds() {
    let truth_effects = Effects::default()
        .with_parameters(EffectKind::JointFriction, &[0.1])
        .with_parameters(EffectKind::SupportFlexibility, &[3e-5]);
    let truth = model(reference_structure(), truth_effects);
    let log = lab_log(&truth, 21);
    let (d, found) = two_found(
        &log,
        [EffectKind::JointFriction, EffectKind::SupportFlexibility],
    );
    assert_eq!(d.rounds.len(), 2);
    for (kind, truth) in [
        (EffectKind::JointFriction, 0.1),
        (EffectKind::SupportFlexibility, 3e-5),
    ] {
        let c = found.iter().find(|c| c.term == Term::Global(kind)).unwrap();
        let (v, se) = (c.values[0], c.std_errors[0]);
        assert!(
            (v - truth).abs() <= 3.0 * se,
            "{}: {v} ± {se} (joint), truth {truth}",
            kind.name()
        );
        // The joint values are what the final model holds.
        assert_eq!(d.hypothesis.parameters(Term::Global(kind)), Some(vec![v]));
    }
}

/// Issue 24: `tdeploy lab` of the default truth (μ = 0.2 and 3 mm
/// backlash, what every deployment test runs on), with its default
/// cycles (0.01, 0.05, 0.1 and 0.4 m in 5 steps), diagnosed "a structured
/// residual remains" on seeds 1–4: the screen linearised friction at
/// μ = 0, where its response is one-sided, predicted it a χ² gain of 0
/// and never fitted it, while the motor alone made the held-out residual
/// worse. (The smaller logs of the other tests did not show it.) Screened
/// also by the χ² the fit's start removes, friction is found, then the
/// motor, and the joint refit gives all three parameters within 3
/// standard errors.
#[test]
fn the_default_truths_friction_and_backlash_are_both_found() {
    let truth = model(
        reference_structure(),
        tensegrity_deploy::sim::default_truth_effects(),
    );
    let cycles = tensegrity_deploy::measure::lab::standard_cycles(
        truth.structure.continuous_cables.len(),
        &[0.01, 0.05, 0.1, 0.4],
        5,
        DAILY_SWING_K,
    );
    let sensors = tensegrity_deploy::sim::standard_sensors(&truth.structure);
    let log = tensegrity_deploy::measure::lab::run_lab(&truth, &sensors, &cycles, 1).unwrap();
    let (_, found) = two_found(&log, [EffectKind::JointFriction, EffectKind::Motor]);
    for (kind, truth) in [
        (EffectKind::JointFriction, vec![0.2]),
        (EffectKind::Motor, vec![0.0, 0.003]),
    ] {
        let c = found.iter().find(|c| c.term == Term::Global(kind)).unwrap();
        for ((v, se), t) in c.values.iter().zip(&c.std_errors).zip(&truth) {
            assert!(
                (v - t).abs() <= 3.0 * se,
                "{}: {v} ± {se} (joint), truth {t}",
                kind.name()
            );
        }
    }
}

/// One strut of the truth 4 mm too long. Before the member rest-length
/// candidate no candidate modelled it and the verdict was a structured
/// residual; with a drum offset added (issue 24, item 5) that offset of
/// the strut's cable explained the log to the noise, confidently, naming
/// the wrong part. Now the strut's own length is fitted (4 mm within three
/// standard errors), and as the struts beside it on the same cable
/// explain the log alike, the verdict names them and is not confident.
#[test]
fn a_strut_too_long_is_named_with_the_members_that_explain_it_alike() {
    let mut long_strut = reference_structure();
    let strut = long_strut
        .members
        .iter()
        .position(|m| matches!(m.kind, MemberKind::Strut { .. }))
        .unwrap();
    long_strut.members[strut].rest_length_m += 0.004;
    let id = long_strut.members[strut].id.clone();
    let log = lab_log(&model(long_strut, Effects::default()), 31);
    let d = diagnose(
        &model(reference_structure(), Effects::default()),
        &log,
        &DiagnoseSettings::default(),
    )
    .unwrap();
    let Verdict::Missing { found, confident } = &d.verdict else {
        panic!("expected the strut found, got {:?}", d.verdict);
    };
    assert!(!confident, "{found:?}");
    let c = &found[0];
    let rivals: Vec<&String> = c
        .flags
        .iter()
        .filter_map(|f| match f {
            ParameterFlag::Rival { name, .. } => Some(name),
            _ => None,
        })
        .collect();
    assert!(!rivals.is_empty(), "{c:?}");
    let named = format!("member_length({id})");
    if c.name == named {
        assert!(
            (c.values[0] - 0.004).abs() <= 3.0 * c.std_errors[0],
            "{c:?}"
        );
    } else {
        assert!(rivals.contains(&&named), "{c:?}");
    }
    // No drum offset is claimed for what a strut did.
    assert!(
        found.iter().all(|c| !c.name.starts_with("drum_offset")),
        "{found:?}"
    );
}

/// The self-diagnosis between cycles refits what a model learnt before
/// from its values (`refit_effects`): from μ = 0.1 and 1 mm of backlash
/// on a log of the default truth (μ = 0.2, 3 mm), the joint refit comes
/// back to the truth within three standard errors or 10 %, lowers the
/// held-out residual, and does not move from values that already fit:
/// refitting its own result changes them by less than a standard error.
#[test]
fn a_refit_from_the_values_learnt_before_reaches_the_truth() {
    use tensegrity_deploy::measure::compare::compare;
    use tensegrity_deploy::measure::diagnose::{part, refit_effects};
    let kinds = [EffectKind::JointFriction, EffectKind::Motor];
    let truth_effects = Effects::default()
        .with_parameters(kinds[0], &[0.2])
        .with_parameters(kinds[1], &[0.0, 0.003]);
    let truth = model(reference_structure(), truth_effects);
    let log = lab_log(&truth, 5);
    let start = model(
        reference_structure(),
        Effects::default()
            .with_parameters(kinds[0], &[0.1])
            .with_parameters(kinds[1], &[0.0, 0.001]),
    );
    let settings = DiagnoseSettings::default();
    let held = |m: &EffectModel| {
        part(
            &compare(m, &log).unwrap(),
            log.cycles.len(),
            true,
            &settings,
        )
        .overall
        .rms
    };
    let r = refit_effects(&start, &kinds, &log, &settings)
        .unwrap()
        .expect("a refit from half the truth lowers the fit's χ²");
    assert!(r.converged);
    assert!(
        r.held_out_rms < held(&start),
        "{} vs {}",
        r.held_out_rms,
        held(&start)
    );
    let mu = r.effects.parameters(kinds[0]).unwrap()[0];
    let backlash = r.effects.parameters(kinds[1]).unwrap()[1];
    let (mu_se, backlash_se) = (r.std_errors[0][0], r.std_errors[1][1]);
    assert!(
        (mu - 0.2).abs() <= (3.0 * mu_se).max(0.02),
        "μ {mu} ± {mu_se}"
    );
    assert!(
        (backlash - 0.003).abs() <= (3.0 * backlash_se).max(0.0003),
        "backlash {backlash} ± {backlash_se}"
    );
    // Refitting its own result: `None` says the fit could not lower χ²
    // from there (the values are its optimum), else it moves them by less
    // than a standard error.
    let again = model(reference_structure(), r.effects.clone());
    match refit_effects(&again, &kinds, &log, &settings).unwrap() {
        None => {}
        Some(r2) => {
            let mu2 = r2.effects.parameters(kinds[0]).unwrap()[0];
            assert!((mu2 - mu).abs() < mu_se, "{mu2} vs {mu} ± {mu_se}");
        }
    }
}
