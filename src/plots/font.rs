//! The bundled font every figure is drawn and embedded with.

use plotters::style::FontStyle;

/// Font family every figure uses: the bundled font by name, then the generic family for an
/// SVG viewer without it. (Also the key the font is registered under for the PNGs.)
pub const FONT: &str = "DejaVu Sans, sans-serif";

/// The bundled font (DejaVu Sans, its licence beside it).
pub(crate) const FONT_BYTES: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");

static FONT_ONCE: std::sync::Once = std::sync::Once::new();

/// Registers the bundled font (once per process).
pub fn register_font() {
    FONT_ONCE.call_once(|| {
        // The bytes are a valid TrueType font checked into the repository; a failure here
        // would be a build defect, so it is reported by the figures' own errors instead.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, FONT_BYTES);
    });
}
