//! A sweep chain's fits started cold against started from the previous cell (issue 16):
//! cells `n_slip` = FIRST..=15 at one down-sampling `d`, on the README's training data (40
//! collect-mode hand releases, seed 1) and scored on its test data (seed 2). Prints each
//! cell's fit time, solver steps and test macro F1 both ways, the time ratio, and how many
//! test predictions differ. Run with `cargo bench --bench warm_start [-- d FIRST]`
//! (default d 1.0, FIRST 11; the chain's first cell is cold either way).

mod common;

use std::time::Instant;

use tmo::slip::dataset::Scope;
use tmo::slip::model::{score_models, ClassifierKind, Hyperparameters, SensorModel};
use tmo::slip::warm::WarmStart;

fn main() {
    let args: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with("--"))
        .collect();
    let d: f64 = args.first().and_then(|a| a.parse().ok()).unwrap_or(1.0);
    let first: usize = args.get(1).and_then(|a| a.parse().ok()).unwrap_or(11);
    let train = common::hand_release_dataset(1, 15, &[0.0]);
    let test = common::hand_release_dataset(2, 15, &[0.0]);
    for (kind, hyper) in [
        (
            ClassifierKind::Logreg,
            Hyperparameters {
                c: 3.989,
                ..Default::default()
            },
        ),
        (
            ClassifierKind::SvmRbf,
            Hyperparameters {
                c: 3.989,
                gamma: 1.0 / 60.0,
                max_iterations: None,
            },
        ),
    ] {
        println!("{} d {d}: n_slip, rows, cold s, warm s, cold steps, warm steps, cold F1, warm F1, predictions differing", kind.name());
        let (mut cold_total, mut warm_total) = (0.0, 0.0);
        let mut start: Option<WarmStart> = None;
        for n_slip in first..=15 {
            let rows = train.with_n_slip(n_slip).unwrap().downsample_static(d, 7);
            let test = test.with_n_slip(n_slip).unwrap();
            let t0 = Instant::now();
            let cold = SensorModel::fit(&rows, None, kind, hyper).unwrap();
            let cold_s = t0.elapsed().as_secs_f64();
            let t0 = Instant::now();
            let (warm, next) =
                SensorModel::fit_from(&rows, None, kind, hyper, start.as_ref()).unwrap();
            let warm_s = t0.elapsed().as_secs_f64();
            start = next;
            let steps = |m: &SensorModel| match &m.classifier {
                tmo::slip::model::Classifier::Svm(s) => s.iterations,
                tmo::slip::model::Classifier::LogReg(l) => l.iterations,
                tmo::slip::model::Classifier::Threshold(_) => 0,
            };
            let f1 = |m: &SensorModel| {
                score_models(std::slice::from_ref(m), Scope::Global, &test)
                    .unwrap()
                    .0
                    .macro_f1
            };
            let mut scratch = Vec::new();
            let differ = (0..test.len())
                .filter(|&i| {
                    cold.predict(test.row(i), &mut scratch)
                        != warm.predict(test.row(i), &mut scratch)
                })
                .count();
            if n_slip > first {
                cold_total += cold_s;
                warm_total += warm_s;
            }
            println!(
                "  {n_slip:2} {:7} {cold_s:7.2} {warm_s:7.2} {:7} {:7} {:.4} {:.4} {differ}/{}",
                rows.len(),
                steps(&cold),
                steps(&warm),
                f1(&cold),
                f1(&warm),
                test.len()
            );
        }
        println!(
            "  cells {}..=15: cold {cold_total:.1} s, warm {warm_total:.1} s, warm/cold {:.2}",
            first + 1,
            warm_total / cold_total
        );
    }
}
