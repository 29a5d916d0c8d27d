#!/usr/bin/env bash
# Fails when the tests would build a dependency a second time: a crate the tool builds
# (`cargo install --path .`) whose features the tests' dev-dependencies change is compiled
# again, with those features, by `cargo test` (issue 69: the whole ONNX runtime once was).
# Each (crate, features) the normal build has must be the same in the build with the tests;
# when it is not, pin the features the tests add in Cargo.toml (see the feature pins there).
set -euo pipefail
cd "$(dirname "$0")/.."
view() {
    cargo tree --workspace --locked -e "$1" -f '{p} {f}' --prefix none | sed 's/ (\*)$//' | sort -u
}
normal=$(view normal,build)
with_tests=$(view normal,build,dev)
twice=$(comm -23 <(printf '%s\n' "$normal") <(printf '%s\n' "$with_tests"))
if [ -n "$twice" ]; then
    echo "these dependencies would be built twice (the tests change their features):" >&2
    printf '%s\n' "$twice" | while read -r crate version _; do
        printf '  %s %s: installed with [%s], tested with [%s]\n' "$crate" "$version" \
            "$(printf '%s\n' "$normal" | awk -v c="$crate" -v v="$version" '$1 == c && $2 == v {print $3}')" \
            "$(printf '%s\n' "$with_tests" | awk -v c="$crate" -v v="$version" '$1 == c && $2 == v {print $3}')" >&2
    done
    echo "pin the tested features in Cargo.toml (the feature pins there say how)" >&2
    exit 1
fi
echo "one build: the tests change no dependency's features ($(printf '%s\n' "$normal" | wc -l) crates)"
