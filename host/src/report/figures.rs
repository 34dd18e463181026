//! The report's pictures, as SVG drawn with plotters: matrices as heat
//! maps, the kinematic tree and the skin's interface trees as diagrams,
//! the latency histogram as bars.

use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};

/// What plotters reports when drawing fails.
pub type DrawError = Box<dyn std::error::Error>;

/// One colour per interface port (tree), repeating after eight.
const TREE_COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// The colour of interface tree `k`.
pub fn tree_colour(k: u8) -> RGBColor {
    TREE_COLOURS[usize::from(k) % TREE_COLOURS.len()]
}

fn centred(size: u32) -> TextStyle<'static> {
    ("sans-serif", size).into_font().color(&BLACK).pos(Pos::new(HPos::Center, VPos::Center))
}

fn anchored(size: u32, h: HPos) -> TextStyle<'static> {
    ("sans-serif", size).into_font().color(&BLACK).pos(Pos::new(h, VPos::Center))
}

/// A matrix of cells: `value(r, c)` in [-1, 1] (booleans as 0 and 1), with
/// row and column labels; colours diverge blue - white - red when `signed`.
pub struct Grid<'a> {
    /// Title above the grid.
    pub title: &'a str,
    /// One label per row.
    pub rows: &'a [String],
    /// One label per column.
    pub columns: &'a [String],
    /// Values in [-1, 1], row major.
    pub values: &'a [Vec<f64>],
    /// Negative values mean something (a colour scale with a legend).
    pub signed: bool,
}

/// Blue for -1, white for 0, red for +1; grey-black for booleans.
fn shade(v: f64, signed: bool) -> RGBColor {
    let v = if v.is_finite() { v.clamp(-1.0, 1.0) } else { 0.0 };
    let fade = |c: u8, t: f64| (255.0 - (255.0 - f64::from(c)) * t).round() as u8;
    if !signed {
        return RGBColor(fade(40, v.abs()), fade(40, v.abs()), fade(40, v.abs()));
    }
    let (r, g, b) = if v >= 0.0 { (214, 39, 40) } else { (31, 119, 180) };
    RGBColor(fade(r, v.abs()), fade(g, v.abs()), fade(b, v.abs()))
}

/// Draws a [`Grid`] into an SVG file.
pub fn grid(path: &Path, g: &Grid<'_>) -> Result<(), DrawError> {
    let cell = if g.rows.len() > 40 { 11 } else { 22 };
    let (left, top, bottom) = (150, 40, 130 + if g.signed { 40 } else { 0 });
    let width = (left + cell * g.columns.len() as u32 + 30).max(420);
    let height = top + cell * g.rows.len() as u32 + bottom;
    let root = SVGBackend::new(path, (width, height)).into_drawing_area();
    root.fill(&WHITE)?;
    root.draw(&Text::new(g.title.to_owned(), (10, 18), ("sans-serif", 16).into_font()))?;
    let label = anchored(if cell > 11 { 12 } else { 9 }, HPos::Right);
    for (r, name) in g.rows.iter().enumerate() {
        let y = (top + cell * r as u32) as i32;
        root.draw(&Text::new(name.clone(), (left as i32 - 6, y + cell as i32 / 2), label.clone()))?;
        for (c, v) in g.values[r].iter().enumerate() {
            let x = (left + cell * c as u32) as i32;
            let fill = shade(*v, g.signed);
            root.draw(&Rectangle::new([(x, y), (x + cell as i32, y + cell as i32)], fill.filled()))?;
            root.draw(&Rectangle::new([(x, y), (x + cell as i32, y + cell as i32)], RGBColor(220, 220, 220)))?;
        }
    }
    let below = (top + cell * g.rows.len() as u32 + 6) as i32;
    let column_label = ("sans-serif", 11).into_font().transform(FontTransform::Rotate90);
    for (c, name) in g.columns.iter().enumerate() {
        let x = (left + cell * c as u32 + cell / 2) as i32 + 5;
        root.draw(&Text::new(name.clone(), (x, below), column_label.clone()))?;
    }
    if g.signed {
        let y = height as i32 - 30;
        root.draw(&Text::new("-1".to_owned(), (left as i32 - 6, y + 6), anchored(11, HPos::Right)))?;
        for k in 0..=40 {
            let x = left as i32 + k * 5;
            let fill = shade(f64::from(k - 20) / 20.0, true);
            root.draw(&Rectangle::new([(x, y), (x + 5, y + 12)], fill.filled()))?;
        }
        root.draw(&Text::new("+1".to_owned(), (left as i32 + 210, y + 6), anchored(11, HPos::Left)))?;
    }
    root.present()?;
    Ok(())
}

/// A node of a drawn tree.
pub struct DrawnNode {
    /// Text in the node.
    pub label: String,
    /// The parent node and the edge's label; `None` for a root.
    pub parent: Option<(usize, String)>,
    /// Colour of the node and of its edge.
    pub colour: RGBColor,
}

/// Positions of a forest laid out top-down: depth gives y, the order of
/// leaves gives x, and a parent sits over the middle of its children.
fn layout(nodes: &[DrawnNode]) -> (Vec<(f64, usize)>, usize, usize) {
    let n = nodes.len();
    let mut children: Vec<Vec<usize>> = vec![Vec::new(); n];
    let mut roots = Vec::new();
    for (i, node) in nodes.iter().enumerate() {
        match node.parent {
            Some((p, _)) if p < n && p != i => children[p].push(i),
            _ => roots.push(i),
        }
    }
    let mut at = vec![(0.0, 0usize); n];
    let mut next_leaf = 0.0;
    let mut deepest = 0;
    // Iterative post-order walk (a cyclic parent list still ends: each node is visited once).
    let mut visited = vec![false; n];
    for &r in &roots {
        let mut stack = vec![(r, 0usize, false)];
        while let Some((i, depth, done)) = stack.pop() {
            if done {
                let xs: Vec<f64> = children[i].iter().filter(|c| visited[**c]).map(|c| at[*c].0).collect();
                let x = if xs.is_empty() {
                    next_leaf += 1.0;
                    next_leaf - 1.0
                } else {
                    (xs[0] + xs[xs.len() - 1]) / 2.0
                };
                at[i] = (x, depth);
                continue;
            }
            if std::mem::replace(&mut visited[i], true) {
                continue;
            }
            deepest = deepest.max(depth);
            stack.push((i, depth, true));
            for &c in children[i].iter().rev() {
                stack.push((c, depth + 1, false));
            }
        }
        next_leaf += 0.5;
    }
    (at, (next_leaf.ceil() as usize).max(1), deepest + 1)
}

/// Draws a forest of labelled nodes, roots on top, with labelled edges;
/// `extra` are further links drawn faintly (e.g. non-tree neighbours).
pub fn forest(
    path: &Path,
    title: &str,
    nodes: &[DrawnNode],
    extra: &[(usize, usize)],
    legend: &[(String, RGBColor)],
) -> Result<(), DrawError> {
    let (at, columns, levels) = layout(nodes);
    let (dx, dy) = if nodes.len() > 30 { (30.0, 48.0) } else { (120.0, 70.0) };
    let (left, top) = (40.0, 60.0);
    let width = (left * 2.0 + dx * columns as f64) as u32;
    let height = (top + dy * levels as f64 + 30.0 + 18.0 * legend.len() as f64) as u32;
    let root: DrawingArea<SVGBackend, Shift> = SVGBackend::new(path, (width.max(420), height)).into_drawing_area();
    root.fill(&WHITE)?;
    root.draw(&Text::new(title.to_owned(), (10, 18), ("sans-serif", 16).into_font()))?;
    let pos = |i: usize| ((left + dx * at[i].0 + dx / 2.0) as i32, (top + dy * at[i].1 as f64) as i32);
    for &(a, b) in extra {
        if a < nodes.len() && b < nodes.len() {
            root.draw(&PathElement::new(vec![pos(a), pos(b)], RGBColor(200, 200, 200)))?;
        }
    }
    let small = nodes.len() > 30;
    for (i, node) in nodes.iter().enumerate() {
        if let Some((p, label)) = &node.parent {
            if *p < nodes.len() {
                root.draw(&PathElement::new(vec![pos(*p), pos(i)], node.colour.stroke_width(2)))?;
                if !label.is_empty() {
                    let (x0, y0) = pos(*p);
                    let (x1, y1) = pos(i);
                    // On the outer side of the edge, so siblings' labels do not meet.
                    let (dx, side) = if x1 < x0 { (-6, HPos::Right) } else { (6, HPos::Left) };
                    let mid = ((x0 + x1) / 2 + dx, (y0 + y1) / 2);
                    root.draw(&Text::new(label.clone(), mid, anchored(11, side)))?;
                }
            }
        }
    }
    for (i, node) in nodes.iter().enumerate() {
        let r = if small { 11 } else { 22 };
        // Opaque, so the edges end at the rim and do not cross the label.
        root.draw(&Circle::new(pos(i), r, WHITE.filled()))?;
        root.draw(&Circle::new(pos(i), r, node.colour.mix(0.25).filled()))?;
        root.draw(&Circle::new(pos(i), r, node.colour.stroke_width(2)))?;
        root.draw(&Text::new(node.label.clone(), pos(i), centred(if small { 9 } else { 12 })))?;
    }
    for (k, (text, colour)) in legend.iter().enumerate() {
        let y = height as i32 - 18 * (legend.len() - k) as i32;
        root.draw(&Rectangle::new([(12, y - 5), (24, y + 5)], colour.filled()))?;
        root.draw(&Text::new(text.clone(), (30, y), anchored(12, HPos::Left)))?;
    }
    root.present()?;
    Ok(())
}

/// Bars of a histogram over `0..x_max`: `bins` as (lower edge, count),
/// each `width` wide; bins past `x_max` are left out.
pub fn histogram(
    path: &Path,
    title: &str,
    x_desc: &str,
    bins: &[(f64, u64)],
    width: f64,
    x_max: f64,
) -> Result<(), DrawError> {
    let root = SVGBackend::new(path, (760, 420)).into_drawing_area();
    root.fill(&WHITE)?;
    let shown: Vec<(f64, u64)> = bins.iter().copied().filter(|b| b.0 < x_max).collect();
    let hi_y = shown.iter().map(|b| b.1).max().unwrap_or(1).max(1) as f64 * 1.05;
    let mut chart = ChartBuilder::on(&root)
        .caption(title, ("sans-serif", 16))
        .margin(12)
        .x_label_area_size(36)
        .y_label_area_size(64)
        .build_cartesian_2d(0.0..x_max, 0.0..hi_y)?;
    chart
        .configure_mesh()
        .x_desc(x_desc)
        .y_desc("frames")
        .x_label_formatter(&|v| format!("{v:.0}"))
        .y_label_formatter(&|v| format!("{v:.0}"))
        .light_line_style(WHITE)
        .draw()?;
    chart.draw_series(
        shown.iter().map(|&(lo, n)| Rectangle::new([(lo, 0.0), (lo + width, n as f64)], TREE_COLOURS[0].filled())),
    )?;
    root.present()?;
    Ok(())
}

/// The skin on the robot seen from the front, the side and above (world
/// frame, metres): the links as bones between joint origins, each cell's
/// estimate as a dot with its z axis as a short stroke, and, when known,
/// its true place as a ring joined to the estimate.
pub struct SkinViews<'a> {
    /// Title above the views.
    pub title: &'a str,
    /// Bones, each from a parent's origin to a child's.
    pub bones: &'a [([f64; 3], [f64; 3])],
    /// Estimated cells: position and unit z axis.
    pub cells: &'a [([f64; 3], [f64; 3])],
    /// True positions, in the order of `cells` (empty when unknown).
    pub truth: &'a [[f64; 3]],
}

/// Draws [`SkinViews`] as three orthographic views side by side.
pub fn skin_views(path: &Path, v: &SkinViews<'_>) -> Result<(), DrawError> {
    let root = SVGBackend::new(path, (1260, 480)).into_drawing_area();
    root.fill(&WHITE)?;
    let root = root.titled(v.title, ("sans-serif", 16))?;
    let points =
        v.bones.iter().flat_map(|(a, b)| [*a, *b]).chain(v.cells.iter().map(|c| c.0)).chain(v.truth.iter().copied());
    let (mut lo, mut hi) = ([f64::INFINITY; 3], [f64::NEG_INFINITY; 3]);
    for p in points.filter(|p| p.iter().all(|x| x.is_finite())) {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    if lo[0] > hi[0] {
        lo = [-1.0; 3];
        hi = [1.0; 3];
    }
    // One scale for all views, so lengths compare.
    let half = (0..3).map(|k| hi[k] - lo[k]).fold(0.1, f64::max) / 2.0 * 1.08;
    let mid: Vec<f64> = (0..3).map(|k| (hi[k] + lo[k]) / 2.0).collect();
    let views =
        [("front (y right to left, z up)", 1, 2, true), ("side (x, z up)", 0, 2, false), ("top (x, y)", 0, 1, false)];
    for (area, (name, h, w, flip)) in root.split_evenly((1, 3)).iter().zip(views) {
        let project = |p: &[f64; 3]| (if flip { -p[h] } else { p[h] }, p[w]);
        let hx = if flip { -mid[h] } else { mid[h] };
        let mut chart = ChartBuilder::on(area)
            .caption(name, ("sans-serif", 13))
            .margin(8)
            .x_label_area_size(24)
            .y_label_area_size(40)
            .build_cartesian_2d(hx - half..hx + half, mid[w] - half..mid[w] + half)?;
        chart
            .configure_mesh()
            .light_line_style(WHITE)
            .x_label_formatter(&|x| format!("{x:.2}"))
            .y_label_formatter(&|y| format!("{y:.2}"))
            .draw()?;
        chart.draw_series(
            v.bones.iter().map(|(a, b)| PathElement::new(vec![project(a), project(b)], BLACK.stroke_width(2))),
        )?;
        let estimate = TREE_COLOURS[0];
        let truth = TREE_COLOURS[3];
        for (i, (p, z)) in v.cells.iter().enumerate() {
            if let Some(t) = v.truth.get(i) {
                chart.draw_series([PathElement::new(vec![project(t), project(p)], truth.stroke_width(1))])?;
                chart.draw_series([Circle::new(project(t), 3, truth.stroke_width(1))])?;
            }
            let tip = [p[0] + 0.03 * z[0], p[1] + 0.03 * z[1], p[2] + 0.03 * z[2]];
            chart.draw_series([PathElement::new(vec![project(p), project(&tip)], estimate.stroke_width(1))])?;
            chart.draw_series([Circle::new(project(p), 2, estimate.filled())])?;
        }
    }
    root.present()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_forest_is_laid_out_by_depth_and_leaves_and_a_cycle_ends() {
        let node = |parent: Option<usize>| DrawnNode {
            label: String::new(),
            parent: parent.map(|p| (p, String::new())),
            colour: BLACK,
        };
        // 0 -> {1, 2}, 2 -> 3; 4 and 5 point at each other (bad input).
        let nodes = [node(None), node(Some(0)), node(Some(0)), node(Some(2)), node(Some(5)), node(Some(4))];
        let (at, columns, levels) = layout(&nodes);
        assert_eq!((at[0].1, at[3].1, levels), (0, 2, 3));
        assert!(at[1].0 < at[2].0 && at[0].0 > at[1].0 && at[0].0 < at[3].0 + 1e-9);
        assert_eq!(columns, 3, "two leaves, a gap after the tree, none for the cycle");
    }

    #[test]
    fn shades_stay_in_range() {
        assert_eq!(shade(0.0, true), RGBColor(255, 255, 255));
        assert_eq!(shade(f64::NAN, true), RGBColor(255, 255, 255));
        assert_eq!(shade(1.0, true), RGBColor(214, 39, 40));
        assert_eq!(shade(-7.0, true), RGBColor(31, 119, 180));
        assert_eq!(shade(1.0, false), RGBColor(40, 40, 40));
    }
}
