//! Values quoted back in messages. f64's `Display` writes every digit: a user's `1e300`
//! came back as 301 digits and `1e-300` as 300 zeros. A number is quoted as written for
//! ordinary sizes and in exponent form beyond them.

/// `x` as a message quotes it: `0.05`, `360`, `-1.5` as they are; `1e300`, `1e-300`
/// (and any magnitude from 1e15 or below 1e-4) in exponent form; `NaN`, `inf` as Rust
/// writes them.
pub fn number(x: f64) -> String {
    let size = x.abs();
    if x == 0.0 || !x.is_finite() || (1e-4..1e15).contains(&size) {
        format!("{x}")
    } else {
        format!("{x:e}")
    }
}

/// A list as a message quotes it: the first `at_most` items joined by commas, then how many
/// more (`a, b, c and 12 more`), so a list of a thousand is one short line.
pub fn list<S: AsRef<str>>(items: &[S], at_most: usize) -> String {
    let shown: Vec<&str> = items.iter().take(at_most).map(AsRef::as_ref).collect();
    match items.len().saturating_sub(at_most) {
        0 => shown.join(", "),
        more => format!("{} and {more} more", shown.join(", ")),
    }
}

/// How many items a message lists before it counts the rest.
pub const LISTED: usize = 5;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn long_lists_are_folded_after_a_few() {
        assert_eq!(list(&["a", "b"], 5), "a, b");
        let many: Vec<String> = (1..=999).map(|k| format!("{k}/1000")).collect();
        assert_eq!(list(&many, 3), "1/1000, 2/1000, 3/1000 and 996 more");
        assert_eq!(list::<&str>(&[], 3), "");
    }

    #[test]
    fn numbers_of_any_size_are_quoted_short() {
        assert_eq!(number(0.05), "0.05");
        assert_eq!(number(360.0), "360");
        assert_eq!(number(-1.5), "-1.5");
        assert_eq!(number(0.0), "0");
        assert_eq!(number(1e300), "1e300");
        assert_eq!(number(-1e-300), "-1e-300");
        assert_eq!(number(f64::NAN), "NaN");
        assert_eq!(number(f64::INFINITY), "inf");
        for x in [f64::MAX, f64::MIN_POSITIVE, 5e-324, 123456789.0e20] {
            assert!(number(x).len() < 30, "{}", number(x));
        }
    }
}
