//! SVM fit time for 2k, 5k, 10k, 20k and all (61k) rows of 60-dimensional simulator
//! features, per-frame prediction latency of the 20k-row model, and its scoring of every
//! row one at a time against several at a time (as a test set or held-out fold is scored).
//! Run with `cargo run --release --example bench_rows` (in the workspace root, once: it
//! writes `target/bench/svm_rows.csv`, shuffled and seeded) and
//! `cargo bench -p tmo-learn --bench svm_speed`; then
//! `python3 scripts/time_sklearn.py target/bench/svm_rows.csv` times scikit-learn's SVC on
//! exactly the same rows and hyperparameters (libsvm runs on one thread; each fit here runs
//! on one thread and then on every core).

mod rows;

use std::time::Instant;

use tmo_learn::scaler::Scaler;
use tmo_learn::svm::SvmParams;

const C: f64 = 3.989;
const GAMMA: f64 = 0.02;
/// Training rows of each timed fit, then every row (61,315: 40 trials at d 0.4, the
/// the step-by-step pipeline's training set's size).
const SIZES: [usize; 4] = [2_000, 5_000, 10_000, 20_000];
/// The fit whose model times per-frame prediction (as `scripts/time_sklearn.py` does).
const PREDICT_ROWS: usize = 20_000;

fn percentile(sorted: &[f64], p: f64) -> f64 {
    sorted[((sorted.len() - 1) as f64 * p).round() as usize]
}

fn main() {
    let ds = rows::read("svm_rows.csv");
    println!(
        "svm_speed: RBF C-SVC, C = {C}, gamma = {GAMMA}, tol 1e-3, {} rows of {} features from target/bench/svm_rows.csv ({} slip)",
        ds.len(),
        ds.dim,
        ds.positives()
    );
    let params = SvmParams::rbf(C, GAMMA).check().unwrap();
    let threads = rayon::current_num_threads();
    let one_thread = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap();
    let mut predictor = None;
    for n in SIZES.into_iter().chain([ds.len()]) {
        assert!(ds.len() >= n, "only {} rows", ds.len());
        let x = &ds.x[..n * ds.dim];
        let y = &ds.y[..n];
        // One thread (as libsvm runs) and every core, on the same rows.
        let fit = || {
            let t0 = Instant::now();
            let scaler = Scaler::fit(ds.dim, x);
            let xs = scaler.transform(x);
            let model = params.fit(ds.dim, &xs, y).unwrap();
            (t0.elapsed().as_secs_f64(), scaler, model)
        };
        let (single, _, _) = one_thread.install(fit);
        let (secs, scaler, model) = fit();
        println!(
            "  fit {n:>6} rows: {single:>7.3} s on 1 thread, {secs:>7.3} s on {threads}  ({} support vectors, {} iterations)",
            model.support_vector_count(),
            model.iterations
        );
        if n == PREDICT_ROWS {
            predictor = Some((scaler, model));
        }
    }
    let (scaler, model) = predictor.unwrap();
    let mut scaled = vec![0.0f32; ds.dim];
    let mut times = Vec::new();
    let mut slips = 0;
    for i in (ds.len() - 5000.min(ds.len())..ds.len())
        .cycle()
        .take(20_000)
    {
        let t0 = Instant::now();
        scaler.transform_into(ds.row(i), &mut scaled);
        let d = model.decision(&scaled);
        times.push(t0.elapsed().as_secs_f64() * 1e6);
        slips += usize::from(d > 0.0);
    }
    times.sort_by(|a, b| a.partial_cmp(b).unwrap());
    println!(
        "  predict one frame against {} support vectors: median {:.1} us, p99 {:.1} us ({} of {} frames slip)",
        model.support_vector_count(),
        percentile(&times, 0.5),
        percentile(&times, 0.99),
        slips,
        times.len()
    );
    // Scoring every row on one thread, one row at a time and several at a time.
    let all = scaler.transform(&ds.x);
    let (alone, alone_s) = one_thread.install(|| {
        let t0 = Instant::now();
        let d: Vec<f64> = all
            .chunks_exact(ds.dim)
            .map(|x| model.decision(x))
            .collect();
        (d, t0.elapsed().as_secs_f64())
    });
    let (together, together_s) = one_thread.install(|| {
        let t0 = Instant::now();
        let mut d = vec![0.0; ds.len()];
        model.decisions(&all, &mut d);
        (d, t0.elapsed().as_secs_f64())
    });
    assert_eq!(alone, together, "the same decision values either way");
    println!(
        "  score {} rows on 1 thread: {alone_s:.3} s one at a time, {together_s:.3} s several at a time (ratio {:.2}, same values)",
        ds.len(),
        together_s / alone_s
    );
    // Classes only (as a test set or held-out fold is scored): rows the slip support
    // vectors alone show static are not summed over the rest (see NegativeBound).
    match model.negative_bound() {
        None => println!(
            "  classes: this model has no static bound (rho <= 0 or mostly slip support vectors)"
        ),
        Some(bound) => {
            let (bounded, bounded_s, spared) = one_thread.install(|| {
                let t0 = Instant::now();
                let sure = bound.surely_negative(&all);
                let left: Vec<f32> = all
                    .chunks_exact(ds.dim)
                    .zip(&sure)
                    .filter(|(_, s)| !**s)
                    .flat_map(|(x, _)| x.iter().copied())
                    .collect();
                let mut d = vec![0.0; left.len() / ds.dim];
                model.decisions(&left, &mut d);
                let mut decided = d.into_iter();
                let slip: Vec<bool> = sure
                    .iter()
                    .map(|s| !s && decided.next().unwrap() > 0.0)
                    .collect();
                let spared = sure.iter().filter(|s| **s).count();
                (slip, t0.elapsed().as_secs_f64(), spared)
            });
            let full: Vec<bool> = together.iter().map(|d| *d > 0.0).collect();
            assert_eq!(bounded, full, "the same classes either way");
            println!(
                "  classes of {} rows on 1 thread: {together_s:.3} s from every decision, {bounded_s:.3} s with the static bound (ratio {:.2}; {spared} rows spared the full sum, same classes)",
                ds.len(),
                bounded_s / together_s
            );
        }
    }
}
