//! The files a figure is written as beside its SVG: a PDF with the bundled font embedded (for
//! LaTeX) and a PNG that states its resolution.

use std::path::Path;

/// Resolution every figure is stated at: [`super::SIZE`] (900 x 600 px) is then 6 x 4 in,
/// a journal's one-and-a-half column width. The PNG is 150 DPI at that size; for print at
/// 300 DPI or more, use the PDF (vector, any size).
pub const DPI: f32 = 150.0;

/// The bundled font's family name, as the SVGs name it first.
const FONT_FAMILY: &str = "DejaVu Sans";

/// Converts the SVG at `svg` into a PDF at `pdf`, `DPI` user units to the inch, with the
/// glyphs of the bundled font it uses embedded.
pub fn svg_to_pdf(svg: &Path, pdf: &Path) -> Result<(), String> {
    use svg2pdf::usvg;
    let text = std::fs::read_to_string(svg).map_err(|e| e.to_string())?;
    let mut fonts = usvg::fontdb::Database::new();
    fonts.load_font_data(super::font::FONT_BYTES.to_vec());
    // The SVG falls back to the generic family after DejaVu Sans: the same font.
    fonts.set_sans_serif_family(FONT_FAMILY);
    let options = usvg::Options {
        fontdb: std::sync::Arc::new(fonts),
        ..usvg::Options::default()
    };
    let tree = usvg::Tree::from_str(&text, &options).map_err(|e| e.to_string())?;
    let page = svg2pdf::PageOptions { dpi: DPI };
    let bytes = svg2pdf::to_pdf(&tree, svg2pdf::ConversionOptions::default(), page)
        .map_err(|e| e.to_string())?;
    crate::output::atomic::write_atomic(pdf, &bytes).map_err(|e| e.to_string())
}

/// Where a PNG is drawn before it is stated and put in place: `.<name>.partial.png` beside
/// it (hidden, and with the extension that tells plotters the format).
pub fn drawing_path(png: &Path) -> std::path::PathBuf {
    let stem = png.file_stem().unwrap_or_default().to_string_lossy();
    png.with_file_name(format!(".{stem}.partial.png"))
}

/// The PNG drawn at `drawn` marked as `DPI` dots per inch (a `pHYs` chunk after the
/// header), so that a document places it at its stated size, written whole to `png`; the
/// drawing is removed. The image itself is unchanged.
pub fn state_png_dpi(drawn: &Path, png: &Path) -> Result<(), String> {
    let bytes = std::fs::read(drawn).map_err(|e| e.to_string())?;
    let _ = std::fs::remove_file(drawn);
    let stated = with_dpi(&bytes, DPI).ok_or("not a PNG with a header chunk")?;
    crate::output::atomic::write_atomic(png, &stated).map_err(|e| e.to_string())
}

/// `png` with a `pHYs` chunk of `dpi` inserted after its `IHDR` (replacing any `pHYs`).
fn with_dpi(png: &[u8], dpi: f32) -> Option<Vec<u8>> {
    const SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
    if !png.starts_with(SIGNATURE) {
        return None;
    }
    // IHDR is first: length (4), type (4), 13 bytes of data, CRC (4)
    let ihdr_end = SIGNATURE.len() + 4 + 4 + 13 + 4;
    if png.get(SIGNATURE.len() + 4..SIGNATURE.len() + 8)? != b"IHDR" || png.len() < ihdr_end {
        return None;
    }
    let per_metre = (dpi / 0.0254).round() as u32;
    let mut chunk = Vec::with_capacity(21);
    chunk.extend_from_slice(&9u32.to_be_bytes());
    chunk.extend_from_slice(b"pHYs");
    chunk.extend_from_slice(&per_metre.to_be_bytes());
    chunk.extend_from_slice(&per_metre.to_be_bytes());
    chunk.push(1); // unit: the metre
    let crc = crc32fast::hash(&chunk[4..]);
    chunk.extend_from_slice(&crc.to_be_bytes());

    let mut out = Vec::with_capacity(png.len() + chunk.len());
    out.extend_from_slice(&png[..ihdr_end]);
    out.extend_from_slice(&chunk);
    // the other chunks, without any earlier pHYs
    let mut at = ihdr_end;
    while at + 8 <= png.len() {
        let len = u32::from_be_bytes(png[at..at + 4].try_into().ok()?) as usize;
        let end = at.checked_add(12 + len)?;
        let chunk = png.get(at..end)?;
        if &chunk[4..8] != b"pHYs" {
            out.extend_from_slice(chunk);
        }
        at = end;
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The pixels per metre a PNG states, and its unit byte, if it states any.
    fn stated(png: &[u8]) -> Option<(u32, u32, u8)> {
        let at = png.windows(4).position(|w| w == b"pHYs")? + 4;
        let x = u32::from_be_bytes(png[at..at + 4].try_into().unwrap());
        let y = u32::from_be_bytes(png[at + 4..at + 8].try_into().unwrap());
        Some((x, y, png[at + 8]))
    }

    fn tiny_png() -> Vec<u8> {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.png");
        {
            use plotters::prelude::*;
            let root = BitMapBackend::new(&path, (4, 3)).into_drawing_area();
            root.fill(&WHITE).unwrap();
            root.present().unwrap();
        }
        std::fs::read(&path).unwrap()
    }

    #[test]
    fn a_png_states_its_dpi_once_and_keeps_its_pixels() {
        let png = tiny_png();
        assert_eq!(stated(&png), None);
        let once = with_dpi(&png, 150.0).unwrap();
        assert_eq!(stated(&once), Some((5906, 5906, 1)));
        // stating it again replaces, never duplicates
        let twice = with_dpi(&once, 300.0).unwrap();
        assert_eq!(twice.windows(4).filter(|w| w == b"pHYs").count(), 1);
        assert_eq!(stated(&twice), Some((11811, 11811, 1)));
        // the chunk's CRC is right, and the rest is the original file
        let at = twice.windows(4).position(|w| w == b"pHYs").unwrap();
        let crc = u32::from_be_bytes(twice[at + 13..at + 17].try_into().unwrap());
        assert_eq!(crc, crc32fast::hash(&twice[at..at + 13]));
        assert_eq!(twice.len(), png.len() + 21);
        assert!(with_dpi(b"GIF89a", 150.0).is_none());
    }

    #[test]
    fn a_pdf_embeds_the_bundled_font_at_the_stated_size() {
        let dir = tempfile::tempdir().unwrap();
        let svg = dir.path().join("f.svg");
        std::fs::write(
            &svg,
            r#"<svg width="900" height="600" viewBox="0 0 900 600" xmlns="http://www.w3.org/2000/svg"><text x="10" y="20" font-family="DejaVu Sans, sans-serif" font-size="16">slip</text></svg>"#,
        )
        .unwrap();
        let pdf = dir.path().join("f.pdf");
        svg_to_pdf(&svg, &pdf).unwrap();
        let bytes = std::fs::read(&pdf).unwrap();
        assert!(bytes.starts_with(b"%PDF-"));
        let text = String::from_utf8_lossy(&bytes);
        assert!(text.contains("DejaVuSans"), "the font is embedded");
        assert!(text.contains("FontFile"), "the font is embedded");
        // 900 x 600 user units at 150 DPI: 6 x 4 in, 432 x 288 pt
        assert!(
            text.contains("/MediaBox [0 0 432 288]"),
            "{}",
            &text[..400.min(text.len())]
        );
    }
}
