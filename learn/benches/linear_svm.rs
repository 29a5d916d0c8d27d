//! Linear C-SVC fits across C, on the rows `tmo train --classifier svm-linear` sees with
//! its defaults (40 collect-mode hand trials, n_slip 13, static rows downsampled to 0.4),
//! scaled as `tmo train` scales them. Run with `cargo run --release --example bench_rows`
//! (in the workspace root, once) and `cargo bench -p tmo-learn --bench linear_svm`.
//!
//! The rows come from `target/bench/linear_rows.csv` and our fits go to
//! `target/bench/linear_fits.json`; `python3 scripts/time_sklearn_linear.py target/bench`
//! then fits scikit-learn's `SVC(kernel="linear")` on the same rows at the same C and prints
//! both side by side (time ratio, weight distance, rows that disagree).
//! `TMO_LINEAR_C=0.1,20` chooses the values of C.

mod rows;

use std::time::Instant;

use tmo_learn::metrics::macro_f1;
use tmo_learn::scaler::Scaler;
use tmo_learn::svm::SvmParams;

fn main() {
    let ds = rows::read("linear_rows.csv");
    let cs: Vec<f64> = std::env::var("TMO_LINEAR_C")
        .unwrap_or_else(|_| "0.1,1,20,100,1000".into())
        .split(',')
        .map(|c| {
            c.trim()
                .parse()
                .expect("TMO_LINEAR_C: numbers separated by commas")
        })
        .collect();
    println!(
        "linear_svm: {} rows of {} features ({} slip), tol 1e-3, from target/bench/linear_rows.csv",
        ds.len(),
        ds.dim,
        ds.positives()
    );
    let scaler = Scaler::fit(ds.dim, &ds.x);
    let xs = scaler.transform(&ds.x);
    let mut fits = Vec::new();
    for c in cs {
        let params = SvmParams::linear(c).check().unwrap();
        let t0 = Instant::now();
        let model = params.fit(ds.dim, &xs, &ds.y).unwrap();
        let secs = t0.elapsed().as_secs_f64();
        let predicted: Vec<bool> = xs.chunks_exact(ds.dim).map(|r| model.predict(r)).collect();
        let f1 = macro_f1(&ds.y, &predicted);
        println!(
            "  C = {c:>7}: {secs:>8.3} s, {:>9} iterations, {} support vectors, training macro F1 {f1:.4}{}",
            model.iterations,
            model.support_vector_count(),
            model
                .unconverged_gap
                .map(|g| format!(", NOT CONVERGED (gap {g:.3})"))
                .unwrap_or_default()
        );
        fits.push(serde_json::json!({
            "C": c,
            "seconds": secs,
            "iterations": model.iterations,
            "support_vectors": model.support_vector_count(),
            "converged": model.unconverged_gap.is_none(),
            "weights": model.weights,
            "rho": model.rho,
        }));
    }
    std::fs::write(
        rows::path("linear_fits.json"),
        serde_json::to_string_pretty(&fits).unwrap(),
    )
    .unwrap();
    println!("  fits written to target/bench/linear_fits.json");
}
