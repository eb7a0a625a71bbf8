//! What both benchmarks share.

/// Registers egui's bundled Ubuntu font as plotters' "sans-serif". Plotters
/// measures text with `ab_glyph` in this workspace (the feature the accuracy
/// chart needs), which finds no system font: without this, the first chart
/// with text, ours or criterion's, panics on a machine without fonts.
pub fn register_chart_font() -> Result<(), &'static str> {
    plotters::style::register_font("sans-serif", plotters::style::FontStyle::Normal, epaint_default_fonts::UBUNTU_LIGHT)
        .map_err(|_| "the bundled chart font does not load")
}
