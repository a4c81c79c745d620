//! Log-log line charts for convergence plots, written as SVG (the chart format: any browser or
//! converter such as `rsvg-convert` turns it into a raster image).
//!
//! The chart is laid out once as a list of primitives (lines, markers, text) in pixel coordinates,
//! which [`Chart::svg`] writes as SVG elements.

use crate::error::Result;
use std::fmt::Write as _;
use std::path::Path;

/// One series on a chart.
#[derive(Clone, Debug)]
pub struct Line {
    /// Legend text.
    pub label: String,
    /// (x, y) points; points with a non-positive or non-finite coordinate are skipped.
    pub points: Vec<(f64, f64)>,
    /// Dashed and without markers (used for theory slopes).
    pub dashed: bool,
    /// Palette index; lines sharing it share a colour.
    pub color: usize,
}

/// A log-log chart.
#[derive(Clone, Debug, Default)]
pub struct Chart {
    /// Title above the plot.
    pub title: String,
    /// Horizontal axis label.
    pub x_label: String,
    /// Vertical axis label.
    pub y_label: String,
    /// The series.
    pub lines: Vec<Line>,
}

const PALETTE: [[u8; 3]; 8] = [
    [0x1f, 0x77, 0xb4],
    [0xd6, 0x27, 0x28],
    [0x2c, 0xa0, 0x2c],
    [0xff, 0x7f, 0x0e],
    [0x94, 0x67, 0xbd],
    [0x8c, 0x56, 0x4b],
    [0xe3, 0x77, 0xc2],
    [0x17, 0xbe, 0xcf],
];
const BLACK: [u8; 3] = [0, 0, 0];
const GRID: [u8; 3] = [0xdd, 0xdd, 0xdd];
const WIDTH: f64 = 1200.0;
const PLOT_H: f64 = 640.0;
const LEFT: f64 = 110.0;
const RIGHT: f64 = 30.0;
const TOP: f64 = 50.0;
const BOTTOM: f64 = 80.0;
const LEGEND_ROW: f64 = 22.0;
/// Glyph scale: font8x8 glyphs drawn 16 pixels high.
const TEXT: f64 = 16.0;

/// The plotted range in log10 units, and its map to pixels.
#[derive(Clone, Copy)]
struct Axes {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
}

impl Axes {
    fn map(&self, (x, y): (f64, f64)) -> (f64, f64) {
        let (px0, px1) = (LEFT, WIDTH - RIGHT);
        let (py0, py1) = (PLOT_H - BOTTOM, TOP);
        let Axes { x0, x1, y0, y1 } = *self;
        (px0 + (x - x0) / (x1 - x0) * (px1 - px0), py0 + (y - y0) / (y1 - y0) * (py1 - py0))
    }
}

/// A line's plottable points in log10 units (non-positive and non-finite ones skipped).
fn log_points(l: &Line) -> Vec<(f64, f64)> {
    l.points
        .iter()
        .filter(|(x, y)| x.is_finite() && y.is_finite() && *x > 0.0 && *y > 0.0)
        .map(|&(x, y)| (x.log10(), y.log10()))
        .collect()
}

/// Line `i` of a chart: its segments, markers and legend row.
fn series(prims: &mut Vec<Prim>, line: &Line, i: usize, axes: &Axes) {
    let color = PALETTE[line.color % PALETTE.len()];
    let p: Vec<(f64, f64)> = log_points(line).into_iter().map(|q| axes.map(q)).collect();
    for w in p.windows(2) {
        prims.push(Prim::Line {
            a: w[0],
            b: w[1],
            color,
            width: if line.dashed { 1.5 } else { 2.0 },
            dashed: line.dashed,
        });
    }
    if !line.dashed {
        prims.extend(p.iter().map(|&at| Prim::Marker { at, color }));
    }
    let y = PLOT_H + i as f64 * LEGEND_ROW;
    prims.push(Prim::Line {
        a: (LEFT, y + TEXT / 2.0),
        b: (LEFT + 40.0, y + TEXT / 2.0),
        color,
        width: 2.0,
        dashed: line.dashed,
    });
    prims.push(Prim::Text {
        at: (LEFT + 52.0, y),
        text: line.label.clone(),
        anchor: Anchor::Start,
        vertical: false,
    });
}

#[derive(Clone, Copy, PartialEq)]
enum Anchor {
    Start,
    Middle,
    End,
}

enum Prim {
    Line { a: (f64, f64), b: (f64, f64), color: [u8; 3], width: f64, dashed: bool },
    Marker { at: (f64, f64), color: [u8; 3] },
    Text { at: (f64, f64), text: String, anchor: Anchor, vertical: bool },
}

/// Tick positions (values) and whether each is labelled, for a log axis spanning [lo, hi]
/// (log10 values).
fn ticks(lo: f64, hi: f64) -> Vec<(f64, bool)> {
    let fine = hi - lo < 2.0;
    let mut out = Vec::new();
    for k in lo.floor() as i32..=hi.ceil() as i32 {
        for m in [1.0, 2.0, 5.0] {
            let v = m * 10f64.powi(k);
            let l = v.log10();
            if l >= lo - 1e-9 && l <= hi + 1e-9 && (m == 1.0 || fine) {
                out.push((v, true));
            } else if l >= lo && l <= hi {
                out.push((v, false));
            }
        }
    }
    out
}

fn tick_label(v: f64) -> String {
    if (1e-3..1e5).contains(&v) {
        let s = format!("{v:.3}");
        let s = s.trim_end_matches('0').trim_end_matches('.');
        s.to_string()
    } else {
        format!("{v:.0e}")
    }
}

impl Chart {
    fn height(&self) -> f64 {
        PLOT_H + (self.lines.len() as f64) * LEGEND_ROW + 20.0
    }

    fn layout(&self) -> Vec<Prim> {
        let all: Vec<(f64, f64)> = self.lines.iter().flat_map(log_points).collect();
        let (mut x0, mut x1, mut y0, mut y1) = all.iter().fold(
            (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY),
            |(a, b, c, d), &(x, y)| (a.min(x), b.max(x), c.min(y), d.max(y)),
        );
        if all.is_empty() {
            (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
        }
        let pad = |lo: f64, hi: f64| {
            let span = (hi - lo).max(0.3);
            let mid = 0.5 * (lo + hi);
            (mid - 0.55 * span, mid + 0.55 * span)
        };
        let (x0, x1) = pad(x0, x1);
        let (y0, y1) = pad(y0, y1);
        let axes = Axes { x0, x1, y0, y1 };
        let mut prims = self.frame(&axes);
        for (i, line) in self.lines.iter().enumerate() {
            series(&mut prims, line, i, &axes);
        }
        prims
    }

    /// Grid lines, tick labels, the frame, the title and the axis labels.
    fn frame(&self, axes: &Axes) -> Vec<Prim> {
        let mut prims = Vec::new();
        let Axes { x0, x1, y0, y1 } = *axes;
        let (px0, px1) = (LEFT, WIDTH - RIGHT);
        let (py0, py1) = (PLOT_H - BOTTOM, TOP);
        // Grid lines and labels: vertical lines for x ticks, horizontal ones for y ticks.
        let x_ticks = ticks(x0, x1).into_iter().map(|(v, l)| (v, l, true));
        for (v, labelled, vertical) in
            x_ticks.chain(ticks(y0, y1).into_iter().map(|(v, l)| (v, l, false)))
        {
            let (a, b, label_at, anchor) = if vertical {
                let (x, _) = axes.map((v.log10(), y0));
                ((x, py0), (x, py1), (x, py0 + 8.0), Anchor::Middle)
            } else {
                let (_, y) = axes.map((x0, v.log10()));
                ((px0, y), (px1, y), (px0 - 8.0, y - TEXT / 2.0), Anchor::End)
            };
            prims.push(Prim::Line { a, b, color: GRID, width: 1.0, dashed: false });
            if labelled {
                let text = tick_label(v);
                prims.push(Prim::Text { at: label_at, text, anchor, vertical: false });
            }
        }
        let frame = [(px0, py0), (px1, py0), (px1, py1), (px0, py1), (px0, py0)];
        for w in frame.windows(2) {
            prims.push(Prim::Line { a: w[0], b: w[1], color: BLACK, width: 1.5, dashed: false });
        }
        let text = |at, text: &str, vertical| Prim::Text {
            at,
            text: text.to_string(),
            anchor: Anchor::Middle,
            vertical,
        };
        prims.push(text((0.5 * (px0 + px1), 14.0), &self.title, false));
        prims.push(text((0.5 * (px0 + px1), py0 + 40.0), &self.x_label, false));
        prims.push(text((20.0, 0.5 * (py0 + py1)), &self.y_label, true));
        prims
    }

    /// The chart as an SVG document.
    pub fn svg(&self) -> String {
        let h = self.height();
        let mut s = String::new();
        let _ = writeln!(
            s,
            r#"<svg xmlns="http://www.w3.org/2000/svg" width="{WIDTH}" height="{h}" viewBox="0 0 {WIDTH} {h}" font-family="monospace" font-size="{TEXT}">"#
        );
        let _ = writeln!(s, r#"<rect width="100%" height="100%" fill="white"/>"#);
        let hex = |c: [u8; 3]| format!("#{:02x}{:02x}{:02x}", c[0], c[1], c[2]);
        for p in self.layout() {
            match p {
                Prim::Line { a, b, color, width, dashed } => {
                    let dash = if dashed { r#" stroke-dasharray="8 5""# } else { "" };
                    let _ = writeln!(
                        s,
                        r#"<line x1="{:.1}" y1="{:.1}" x2="{:.1}" y2="{:.1}" stroke="{}" stroke-width="{width}"{dash}/>"#,
                        a.0,
                        a.1,
                        b.0,
                        b.1,
                        hex(color)
                    );
                }
                Prim::Marker { at, color } => {
                    let _ = writeln!(
                        s,
                        r#"<circle cx="{:.1}" cy="{:.1}" r="3" fill="{}"/>"#,
                        at.0,
                        at.1,
                        hex(color)
                    );
                }
                Prim::Text { at, text, anchor, vertical } => {
                    let anchor = match anchor {
                        Anchor::Start => "start",
                        Anchor::Middle => "middle",
                        Anchor::End => "end",
                    };
                    let text = text.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;");
                    let (x, y) = (at.0, at.1 + TEXT * 0.8);
                    let rotate = if vertical {
                        format!(r#" transform="rotate(-90 {:.1} {:.1})""#, at.0, at.1)
                    } else {
                        String::new()
                    };
                    let y = if vertical { at.1 + TEXT * 0.3 } else { y };
                    let _ = writeln!(
                        s,
                        r#"<text x="{x:.1}" y="{y:.1}" text-anchor="{anchor}"{rotate}>{text}</text>"#
                    );
                }
            }
        }
        s.push_str("</svg>\n");
        s
    }

    /// Writes the SVG file.
    pub fn write_svg(&self, path: &Path) -> Result<()> {
        crate::output::write_bytes(path, self.svg().as_bytes())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ticks_cover_decades() {
        let t = ticks(-2.2, 1.3);
        let labelled: Vec<f64> = t.iter().filter(|t| t.1).map(|t| t.0).collect();
        assert_eq!(labelled, vec![0.01, 0.1, 1.0, 10.0]);
    }

    #[test]
    fn svg_draws_series_in_colour() {
        let chart = Chart {
            title: "t".into(),
            x_label: "x".into(),
            y_label: "y".into(),
            lines: vec![Line {
                label: "a <b>".into(),
                points: vec![(1.0, 1.0), (10.0, 0.1), (100.0, 0.01)],
                dashed: false,
                color: 1,
            }],
        };
        let svg = chart.svg();
        let red = format!("#{:02x}{:02x}{:02x}", PALETTE[1][0], PALETTE[1][1], PALETTE[1][2]);
        assert_eq!(svg.matches("<circle").count(), 3, "one marker per point");
        assert!(svg.matches(&format!("stroke=\"{red}\"")).count() >= 2, "segments in colour");
        assert!(svg.contains("a &lt;b&gt;") && svg.ends_with("</svg>\n"));
    }
}
