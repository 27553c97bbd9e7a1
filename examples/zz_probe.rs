// scratch probe: per-command details, nominal vs exact supports
use tensegrity_deploy::control::support_compliance::model_on_supports;
use tensegrity_deploy::control::{deploy_guided, fold_truth, ClosedLoopSetup, Guidance};
use tensegrity_deploy::design::reference_bridge::{reference_bridge, BridgeParameters};
use tensegrity_deploy::io::evaluation_files::read_distribution;
use tensegrity_deploy::io::policy_file::read_policy;
use tensegrity_deploy::model::{DeploymentState, IncrementObserver, RelaxReport};
use tensegrity_deploy::model::{ForwardModel, JointFriction, RelaxSettings};
use tensegrity_deploy::plan::DeploymentProblem;
use tensegrity_deploy::sim::Plant;
struct MinRow {
    model: ForwardModel,
    row: usize,
    min: f64,
}
impl IncrementObserver for MinRow {
    fn on_increment(&mut self, _: usize, _: usize, _: &RelaxReport, s: &DeploymentState) {
        let f = tensegrity_deploy::plan::limits::force_rows(&self.model, s);
        self.min = self.min.min(f[self.row]);
    }
}
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let a: Vec<String> = std::env::args().skip(1).collect();
    let distribution = read_distribution(std::path::Path::new(&a[0]))?;
    let seed: u64 = a[1].parse()?;
    let i: usize = a[2].parse()?;
    let policy = read_policy(std::path::Path::new(&a[3]))?;
    let bridge = reference_bridge(&BridgeParameters::default())?;
    let nominal = ForwardModel::new(
        bridge.clone(),
        JointFriction::frictionless(),
        RelaxSettings::default(),
    )?;
    let base = DeploymentProblem::default();
    let s = distribution.draw(seed, i);
    let truth = s.truth(&bridge);
    let c = truth
        .effects
        .support_flexibility
        .map_or(0.0, |e| e.compliance_m_per_n);
    println!("effects {:?}", truth.effects);
    s.with_setup(&bridge, &nominal, &base, &policy, |setup| {
        let folded = fold_truth(setup).unwrap();
        for cc in [0.0, c] {
            let model = model_on_supports(&nominal, cc).unwrap();
            let setup = ClosedLoopSetup { model: &model, ..*setup };
            let d = deploy_guided(&setup, &Guidance::default(), Some(&mut folded.clone()), &mut ()).unwrap();
            println!("== compliance {cc:.3e}: {:?} final payout scale {:?}", d.status, d.final_payout_scale);
            for r in &d.records {
                let mg = r.measured_gaps_m.iter().flatten().copied().fold(0.0, f64::max);
                let pg = r.predicted_gaps_m.iter().copied().fold(0.0, f64::max);
                let u = r.command_m.iter().map(|x| x.abs()).fold(0.0, f64::max); println!("   sent {:?}", r.command_m.iter().map(|x| (x*1e4).round()/10.0).collect::<Vec<_>>());
                println!("{:2} tr {:?} |u| {:.4} pred {:.4} meas {:.4} true {:.4} model_util {:.2} truth_util {:.2} tmin {:.1} rej {} act {:?}",
                    r.index, r.trust_region_m.map(|t| (t*1000.0).round()/1000.0), u, pg, mg,
                    r.true_gaps_m.iter().copied().fold(0.0, f64::max), r.model_worst_utilisation, r.truth_worst_utilisation, r.truth_min_tension_n, r.rejected_trials, r.active_constraints);
                for v in &r.truth_violations { println!("     VIOL {}", v.describe()); }
            }
            if cc == 0.0 { continue; }
            let row_name = std::env::var("ROW").unwrap_or("cable B_axial_m0_0".into());
            let row = (0..2000).find(|&r| tensegrity_deploy::plan::limits::force_row_name(&bridge, r) == row_name).unwrap();
            let starts = setup.problem.motor_limits(bridge.continuous_cables.len()).unwrap().start_payout_m;
            let names = ["all","-friction","-motor","-stiffness","-thermal","-mass","-eccentricity","-supports","-faults","only supports+ecc","only supports"];
            for (k, name) in names.iter().enumerate() {
                let mut v = truth.clone();
                let e = &mut v.effects;
                match k { 1 => e.joint_friction = None, 2 => e.motor = None, 3 => e.stiffness_error = None, 4 => e.thermal = None,
                    5 => e.joint_mass_error = None, 6 => e.joint_eccentricity = None, 7 => e.support_flexibility = None,
                    8 => e.faults = Default::default(),
                    9 => { let (a,b) = (e.support_flexibility, e.joint_eccentricity); *e = Default::default(); e.support_flexibility = a; e.joint_eccentricity = b; }
                    10 => { let a = e.support_flexibility; *e = Default::default(); e.support_flexibility = a; }
                    _ => {} }
                let mut plant = Plant::new(&v, Some(&starts), setup.temperature_c).unwrap();
                let mut obs = MinRow { model: plant.model().clone(), row, min: f64::INFINITY };
                let mut mins = Vec::new();
                for r in &d.records { obs.min = f64::INFINITY; plant.apply(&r.command_m, setup.temperature_c, &mut obs).unwrap(); mins.push(obs.min); }
                println!("{name:>20}: min {row_name} per command {:?}", mins.iter().map(|m| (m*10.0).round()/10.0).collect::<Vec<_>>());
            }
        }
    });
    Ok(())
}
