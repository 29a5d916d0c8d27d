fn main() {
    let base = tmo_hal::sim::SimConfig::default();
    for o in [
        "crisps_can",
        "windex_bottle",
        "bleach_bottle",
        "mustard_bottle",
        "banana",
    ] {
        let c = tmo::sim_presets::contact_closure(&base, o).unwrap();
        let h1 = tmo::sim_presets::holding_closure(&base, o, 0.0, 1.2).unwrap();
        let h2 = tmo::sim_presets::holding_closure(&base, o, 0.0, 1.8).unwrap();
        println!(
            "{o}: contact {c:.4} hold1.2 {h1:.4} (+{:.4}) hold1.8 {h2:.4} (+{:.4})",
            h1 - c,
            h2 - c
        );
    }
}
