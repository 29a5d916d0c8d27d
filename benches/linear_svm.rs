//! Linear C-SVC fits across C, on the rows `tmo train --classifier svm-linear` sees with
//! its defaults (40 collect-mode hand trials, n_slip 13, static rows downsampled to 0.4),
//! scaled as `tmo train` scales them. Run with `cargo bench --bench linear_svm`.
//!
//! The rows go to `target/bench/linear_rows.csv` and our fits to
//! `target/bench/linear_fits.json`; `python3 scripts/time_sklearn_linear.py target/bench`
//! then fits scikit-learn's `SVC(kernel="linear")` on the same rows at the same C and prints
//! both side by side (time ratio, weight distance, rows that disagree).
//! `TMO_LINEAR_C=0.1,20` chooses the values of C.

mod common;

use std::time::Instant;

use tmo::slip::metrics::macro_f1;
use tmo::slip::scaler::Scaler;
use tmo::slip::svm::SvmParams;
use tmo::slip::Class;
use tmo_learn::Label;

fn main() {
    let ds = common::hand_release_rows(1, &[0.0]);
    std::fs::create_dir_all("target/bench").unwrap();
    ds.write_csv(std::path::Path::new("target/bench/linear_rows.csv"))
        .unwrap();
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
        "linear_svm: {} rows of {} features ({} slip), tol 1e-3, written to target/bench/linear_rows.csv",
        ds.len(),
        ds.dim,
        ds.count(Class::Slip)
    );
    let scaler = Scaler::fit(ds.dim, &ds.x);
    let xs = scaler.transform(&ds.x);
    let mut fits = Vec::new();
    for c in cs {
        let params = SvmParams::linear(c).check().unwrap();
        let t0 = Instant::now();
        let model = params.fit(ds.dim, &xs, &ds.y).unwrap();
        let secs = t0.elapsed().as_secs_f64();
        let predicted: Vec<Class> = xs
            .chunks_exact(ds.dim)
            .map(|r| Class::from_positive(model.predict(r)))
            .collect();
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
        "target/bench/linear_fits.json",
        serde_json::to_string_pretty(&fits).unwrap(),
    )
    .unwrap();
    println!("  fits written to target/bench/linear_fits.json");
}
