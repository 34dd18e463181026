//! The along-axis part of a cell's position from the skin's own geometry.
//!
//! On a link moved by a single joint the motion shows every cell's
//! position except along that joint's axis, and all cells of the link
//! share that blind direction: neighbours on the same link only tell the
//! patch's shape along the axis, never where it sits. What anchors it is a
//! neighbour whose position is known, on another link (a patch wired
//! across a joint), related to this link by the known kinematics in the
//! start posture (the posture the skin was laid in).
//!
//! Two wired cells are one cell pitch apart (within the connectors'
//! tolerance), and the chord between two cells of one link lies in its
//! surface: on a surface of constant curvature it is perpendicular to the
//! mean of the two normals, which the gravity fit knows well. The pitch
//! gives the along-axis step up to its sign, the chord's tangency gives it
//! directly where the normals lean on the axis (not across a joint, where
//! the two links' surfaces need not meet). A sign one wire leaves open the
//! others may settle: the link's places are fitted over every choice of
//! the open signs, and a choice whose loops and anchors do not close is
//! ruled out. Where that does not settle a place within the asked spread,
//! or no chain of wires reaches a known cell, the direction stays
//! unobservable. Neighbour tables are trusted only where both cells name
//! each other on the same ports, and a wire that cannot be a pitch long is
//! dropped.

use std::collections::HashMap;

use nalgebra::{DMatrix, DVector, Isometry3, Matrix3, Point3, Vector3};
use skin_model::robot::Robot as Model;
use skin_protocol::message::NeighbourReport;
use skin_protocol::Address;

use super::{at_rest_full, CellPose};

/// Bounds are taken this many standard deviations out.
const BOUND_SIGMAS: f64 = 3.0;
/// The motion fit's cells are about a millimetre off in 3D on average,
/// about twice the spread it claims; where the pitch is read from the
/// chord's known part, that part is taken this much less certain, m.
const FIT_FLOOR_M: f64 = 0.001;
/// Points over the pitch's tolerance where the along-axis step is sampled.
const PITCH_NODES: usize = 8;
/// The pitch's two signs are read apart where they are this many of
/// their spreads from zero.
const SIGNS_APART: f64 = 2.0;
/// A step that disagrees with another estimate of it by more than this
/// many standard deviations is a wrong wire (or the wrong sign).
const CONFLICT_SIGMAS: f64 = 4.0;
/// The other sign of the pitch's step is ruled out beyond this many.
const EXCLUDE_SIGMAS: f64 = 5.0;
/// How far the chord may lean out of the normals' bisector per unit of
/// half the turn between them (0 on a surface of constant curvature, up to
/// 1 across a sharp edge), as a standard deviation.
const CURVATURE_SHARE: f64 = 0.5;
/// The accelerometer's z axis is the cell's normal to within its mounting
/// error, rad (datasheet misalignment, as one standard deviation and more).
const MOUNT_SIGMA_RAD: f64 = 0.035;
/// Cells of one link whose blind directions differ more than this are not
/// chained, rad.
const AXIS_AGREEMENT_RAD: f64 = 0.02;

/// What the skin's geometry is taken to be.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NeighbourConfig {
    /// Centre-to-centre distance of wired cells, m.
    pub pitch_m: f64,
    /// The pitch varies by up to this fraction either way.
    pub pitch_tolerance: f64,
    /// An along-axis position is given when its standard deviation is at most this, m.
    pub max_sigma_m: f64,
}

impl Default for NeighbourConfig {
    fn default() -> Self {
        NeighbourConfig {
            pitch_m: skin_model::skin::CELL_PITCH_M,
            pitch_tolerance: skin_model::skin::PITCH_TOLERANCE,
            max_sigma_m: 0.005,
        }
    }
}

/// The chord from a cell `a` to a wired neighbour `b` in `a`'s link frame:
/// `offset + step * axis`, `step` unknown.
#[derive(Clone, Copy, Debug)]
pub struct Chord {
    /// The known part of the chord, m.
    pub offset: Vector3<f64>,
    /// Its covariance, m^2.
    pub offset_covariance: Matrix3<f64>,
    /// The blind direction (unit).
    pub axis: Vector3<f64>,
    /// Outward normals of the two cells (unit).
    pub normals: [Vector3<f64>; 2],
    /// Standard deviation of each normal's direction, rad.
    pub normal_sigma_rad: f64,
    /// The cells are on two links: their surfaces need not meet (a step
    /// or a gap where the patches join; the simulated robots' chords leave
    /// them by up to 0.4 rad and more), so the tangency says nothing.
    pub across_joint: bool,
}

/// A reading of a step: its value and standard deviation, m.
pub type Reading = (f64, f64);

/// What a wire says of its chord's unknown step: the pitch's reading and,
/// where the normals lean on the axis, the tangency's, kept apart so that
/// the fit of the whole link weighs each by its own spread (neither
/// alone is as narrow as both, and each checks the other).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Step {
    /// One step from the pitch (its two signs meet, or the tangency rules
    /// one out).
    Known {
        /// The pitch's reading.
        pitch: Reading,
        /// The tangency's reading, if the normals lean on the axis.
        tangent: Option<Reading>,
    },
    /// Two steps from the pitch (its sign) that this wire's normals cannot
    /// choose between: the link's other wires may.
    Either {
        /// The pitch's two readings.
        pitch: [Reading; 2],
        /// The tangency's reading, if the normals lean on the axis.
        tangent: Option<Reading>,
    },
    /// No step makes the cells a pitch apart along the surface: a wrong wire.
    Impossible,
}

/// The step of `chord` that puts its cells a pitch apart along their surface.
pub fn step(chord: &Chord, cfg: &NeighbourConfig) -> Step {
    let u = chord.axis;
    let c = chord.offset.dot(&u);
    let h = (chord.offset - c * u).norm();
    let offset_sigma = chord.offset_covariance.symmetric_eigenvalues().max().max(0.0).sqrt().hypot(FIT_FLOOR_M);
    let along_sigma = (u.transpose() * chord.offset_covariance * u)[0].max(0.0).sqrt();
    let pitch_sigma = cfg.pitch_m * cfg.pitch_tolerance / 3f64.sqrt();
    let d_sigma = pitch_sigma.hypot(offset_sigma);
    if h > cfg.pitch_m + BOUND_SIGMAS * d_sigma {
        return Step::Impossible;
    }
    // The size of the along-axis part over the pitch's tolerance (uniform)
    // and the known part's error (three-point Gauss-Hermite), where the
    // chord can be a pitch long; a pitch shorter than the known part adds
    // a zero step, so a step near zero keeps its weight.
    let mut moments = [0.0; 3];
    for (dh, wh) in [(-3f64.sqrt(), 1.0 / 6.0), (0.0, 2.0 / 3.0), (3f64.sqrt(), 1.0 / 6.0)] {
        for k in 0..PITCH_NODES {
            let d = cfg.pitch_m * (1.0 + cfg.pitch_tolerance * ((2 * k + 1) as f64 / PITCH_NODES as f64 - 1.0));
            let e = (d * d - (h + dh * offset_sigma).powi(2)).max(0.0).sqrt();
            let w = wh / PITCH_NODES as f64;
            moments = [moments[0] + w, moments[1] + w * e, moments[2] + w * e * e];
        }
    }
    let s = moments[1] / moments[0];
    let spread = (moments[2] / moments[0] - s * s).max(0.0).sqrt();
    // Two readings where the signs stand apart, else one about zero
    // covering both.
    let pitch: Vec<Reading> = if s >= SIGNS_APART * spread {
        let sigma = spread.hypot(along_sigma);
        vec![(-c + s, sigma), (-c - s, sigma)]
    } else {
        vec![(-c, s.hypot(spread).hypot(along_sigma))]
    };
    // The chord lies across the normals' bisector.
    let [na, nb] = chord.normals;
    let bisector = (na + nb).try_normalize(1e-9);
    let tangent = bisector.filter(|_| !chord.across_joint).and_then(|m| {
        let lean = u.dot(&m);
        let turn = na.angle(&nb);
        let angle_sigma = chord.normal_sigma_rad.hypot(CURVATURE_SHARE * (turn / 2.0).sin());
        let sigma = (cfg.pitch_m * angle_sigma).hypot((m.transpose() * chord.offset_covariance * m)[0].max(0.0).sqrt())
            / lean.abs();
        (lean.abs() > 1e-6).then(|| (-chord.offset.dot(&m) / lean, sigma))
    });
    let apart = |(a, sa): Reading, (b, sb): Reading| (a - b).abs() / sa.hypot(sb);
    match (pitch.as_slice(), tangent) {
        (&[one], _) if tangent.is_some_and(|t| apart(one, t) > CONFLICT_SIGMAS) => Step::Impossible,
        (&[one], _) => Step::Known { pitch: one, tangent },
        (&[plus, minus], Some(t)) => {
            let (zp, zm) = (apart(plus, t), apart(minus, t));
            let (near, far) = if zp <= zm { (plus, zm) } else { (minus, zp) };
            if zp.min(zm) > CONFLICT_SIGMAS {
                Step::Impossible
            } else if far >= EXCLUDE_SIGMAS {
                Step::Known { pitch: near, tangent }
            } else {
                Step::Either { pitch: [plus, minus], tangent }
            }
        }
        (&[plus, minus], None) => Step::Either { pitch: [plus, minus], tangent },
        _ => Step::Impossible,
    }
}

/// What resolving the cells' blind directions did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct Resolved {
    /// Cells whose along-axis position now comes from their neighbours.
    pub cells: usize,
    /// Wires that took part in an anchored fit with their step's sign settled.
    pub wires: usize,
    /// Wires one cell reports and its neighbour does not (ignored).
    pub one_sided: usize,
    /// Wires that cannot be a pitch long, or contradict the others (dropped).
    pub dropped: usize,
    /// Wires of an anchored fit whose step's sign neither their normals
    /// nor the other wires could choose.
    pub ambiguous: usize,
}

/// A cell with one blind direction, on `body`.
struct Node {
    cell: usize,
    axis: Vector3<f64>,
}

/// One reading of a link's steps: `t[b] - t[a]` is one of `steps` (`a`
/// `None`: `t[b]` itself), from wire number `wire`.
struct Equation {
    a: Option<usize>,
    b: usize,
    steps: Vec<Reading>,
    wire: usize,
}

/// Gives the cells of `cells` whose position is blind along one direction
/// that direction from the neighbour `tables`, where a chain of wires
/// anchors it on a cell known in 3D; `start` is the posture (description
/// DoF order) in which wires across joints are a pitch long.
pub fn resolve(
    cells: &mut [CellPose],
    model: &Model,
    start: &[f64],
    tables: &[(Address, NeighbourReport)],
    cfg: &NeighbourConfig,
) -> Resolved {
    let mut out = Resolved::default();
    let index: HashMap<Address, usize> = cells.iter().enumerate().map(|(i, c)| (c.id, i)).collect();
    let wires = mutual_wires(tables, &index, &mut out);
    let poses: Vec<Isometry3<f64>> = at_rest_full(model, start).iter().map(|s| s.pose).collect();
    let known = |c: &CellPose| c.unobservable.is_empty() && c.from_neighbours.is_empty() && usable(c);
    let mut bodies: Vec<usize> = cells.iter().filter(|c| blind_once(c)).map(|c| c.body).collect();
    bodies.sort_unstable();
    bodies.dedup();
    for body in bodies {
        // The link's blind direction, every node's sign turned to agree.
        let mut nodes: Vec<Node> = Vec::new();
        for (i, c) in cells.iter().enumerate().filter(|(_, c)| c.body == body && blind_once(c)) {
            let mut axis = c.unobservable[0];
            if let Some(first) = nodes.first() {
                axis *= axis.dot(&first.axis).signum();
                if axis.angle(&first.axis) > AXIS_AGREEMENT_RAD {
                    continue;
                }
            }
            nodes.push(Node { cell: i, axis });
        }
        let node_of: HashMap<usize, usize> = nodes.iter().enumerate().map(|(k, n)| (n.cell, k)).collect();
        let mut equations = Vec::new();
        for (wire, &(i, j)) in wires.iter().enumerate() {
            for (a, b) in [(i, j), (j, i)] {
                let Some(&ka) = node_of.get(&a) else { continue };
                let (ca, cb) = (&cells[a], &cells[b]);
                let axis = nodes[ka].axis;
                let to_link = poses[body].inverse() * poses[cb.body];
                let (offset, covariance, unknown_b) = match node_of.get(&b) {
                    // Both on this link: each cell's own blind part is zero.
                    Some(&kb) if ka < kb => {
                        (cb.position - ca.position, cb.position_covariance_m2 + ca.position_covariance_m2, Some(kb))
                    }
                    Some(_) => continue,
                    None if known(cb) && cb.body != body => {
                        let r = to_link.rotation.to_rotation_matrix().into_inner();
                        let x = to_link * Point3::from(cb.position);
                        (
                            x.coords - ca.position,
                            r * cb.position_covariance_m2 * r.transpose() + ca.position_covariance_m2,
                            None,
                        )
                    }
                    None => continue,
                };
                let chord = Chord {
                    offset,
                    offset_covariance: covariance,
                    axis,
                    normals: [ca.frame * Vector3::z(), to_link.rotation * (cb.frame * Vector3::z())],
                    normal_sigma_rad: ca.orientation_sigma_rad.max(cb.orientation_sigma_rad).hypot(MOUNT_SIGMA_RAD),
                    across_joint: unknown_b.is_none(),
                };
                // The chord is offset + (t_b - t_a) axis; for a known b, -t_a.
                let equation = |steps: &[Reading]| match unknown_b {
                    Some(kb) => Equation { a: Some(ka), b: kb, steps: steps.to_vec(), wire },
                    None => Equation { a: None, b: ka, steps: steps.iter().map(|&(v, s)| (-v, s)).collect(), wire },
                };
                let (pitch, tangent) = match step(&chord, cfg) {
                    Step::Known { pitch, tangent } => (equation(&[pitch]), tangent),
                    Step::Either { pitch, tangent } => (equation(&pitch), tangent),
                    Step::Impossible => {
                        out.dropped += 1;
                        continue;
                    }
                };
                equations.push(pitch);
                equations.extend(tangent.map(|t| equation(&[t])));
            }
        }
        let solved = solve(nodes.len(), &equations);
        out.wires += solved.settled;
        out.ambiguous += solved.undecided;
        out.dropped += solved.dropped;
        for (node, t) in nodes.iter().zip(solved.along) {
            let Some((t, sigma)) = t.filter(|(_, s)| *s <= cfg.max_sigma_m) else { continue };
            let c = &mut cells[node.cell];
            c.position += node.axis * t;
            c.position_covariance_m2 += node.axis * node.axis.transpose() * (sigma * sigma);
            c.position_sigma_m = c.position_covariance_m2.diagonal().map(|v| v.max(0.0).sqrt());
            c.unobservable.clear();
            c.from_neighbours = vec![node.axis];
            out.cells += 1;
        }
    }
    out
}

/// A cell whose link and frame are trusted.
fn usable(c: &CellPose) -> bool {
    c.orientation_observable && !c.inconsistent && c.ambiguous_with.is_empty()
}

/// A trusted cell blind along exactly one direction.
fn blind_once(c: &CellPose) -> bool {
    c.unobservable.len() == 1 && usable(c)
}

/// Pairs of cells (indices) that name each other on matching ports; a
/// wire only one end reports is counted and left out.
fn mutual_wires(
    tables: &[(Address, NeighbourReport)],
    index: &HashMap<Address, usize>,
    out: &mut Resolved,
) -> Vec<(usize, usize)> {
    let table: HashMap<Address, &NeighbourReport> = tables.iter().map(|(id, r)| (*id, r)).collect();
    let mut wires = Vec::new();
    for (id, report) in tables {
        for (port, n) in report.neighbours.iter().enumerate() {
            let Some(n) = n else { continue };
            let back = table.get(&n.id).and_then(|r| r.neighbours[n.port as usize]);
            let mutual = back.is_some_and(|b| b.id == *id && b.port as usize == port);
            match (index.get(id), index.get(&n.id)) {
                (Some(&a), Some(&b)) if mutual && a < b => wires.push((a, b)),
                (Some(_), Some(_)) if !mutual => out.one_sided += 1,
                _ => {}
            }
        }
    }
    wires
}

/// The along-axis places a link's wires give, and what became of the wires.
struct Solved {
    /// Each node's place and its standard deviation, where an anchored chain reaches it.
    along: Vec<Option<Reading>>,
    /// Wires of anchored chains whose sign is settled.
    settled: usize,
    /// Wires of anchored chains whose sign stays open.
    undecided: usize,
    /// Wires of chains that contradict themselves.
    dropped: usize,
}

/// Least squares of the nodes' places from `equations`, per chain of
/// wires anchored on a known cell, over every choice of the two-way
/// (pitch's sign) readings: a choice whose loops and anchors do not close
/// is ruled out, so wires that each leave the sign open may settle it
/// together. Each node gets the mixture of the choices that fit about as
/// well as the best (weighted by their likelihood), so a sign left open
/// widens its spread instead of being guessed. `None` for a node no
/// anchored chain reaches, and for every node of a chain that no choice
/// fits within chance (which wire is wrong cannot be told).
fn solve(nodes: usize, equations: &[Equation]) -> Solved {
    let chain = chains(nodes, equations);
    let mut out = Solved { along: vec![None; nodes], settled: 0, undecided: 0, dropped: 0 };
    for id in 0..nodes {
        let members: Vec<usize> = (0..nodes).filter(|&k| chain[k] == id).collect();
        let used: Vec<&Equation> = equations.iter().filter(|e| chain[e.b] == id).collect();
        if members.is_empty() || !used.iter().any(|e| e.a.is_none()) {
            continue;
        }
        let col: HashMap<usize, usize> = members.iter().enumerate().map(|(c, &k)| (k, c)).collect();
        let row = |e: &Equation, (step, sigma): Reading| Row { a: e.a.map(|a| col[&a]), b: col[&e.b], step, sigma };
        let fixed: Vec<Row> = used.iter().filter(|e| e.steps.len() == 1).map(|e| row(e, e.steps[0])).collect();
        let two_way = reached_first(used.iter().copied().filter(|e| e.steps.len() > 1).collect(), &fixed, &col);
        let mut search = Search {
            nodes: members.len(),
            bound: chance(used.len(), members.len()),
            budget: MAX_FITS,
            found: Vec::new(),
        };
        let mut rows = fixed.clone();
        let open: Vec<Vec<Row>> = two_way.iter().map(|e| e.steps.iter().map(|&r| row(e, r)).collect()).collect();
        let complete = search.explore(&mut rows, &open, &mut Vec::new());
        let mut all: Vec<usize> = used.iter().map(|e| e.wire).collect();
        all.sort_unstable();
        all.dedup();
        let (found, open_wires) = if complete {
            let best = search.found.iter().map(|f| f.chi2).fold(f64::INFINITY, f64::min);
            let kept: Vec<Fit> =
                search.found.into_iter().filter(|f| f.chi2 <= best + EXCLUDE_SIGMAS * EXCLUDE_SIGMAS).collect();
            let open: Vec<usize> = two_way
                .iter()
                .enumerate()
                .filter(|(k, _)| kept.iter().any(|f| f.choice[*k] != kept[0].choice[*k]))
                .map(|(_, e)| e.wire)
                .collect();
            (kept, open)
        } else {
            // Too many choices fit to weigh them all: the two-way readings are left out.
            let bound = chance(fixed.len(), members.len());
            let mut only_fixed = Search { nodes: members.len(), bound, budget: 1, found: Vec::new() };
            only_fixed.explore(&mut fixed.clone(), &[], &mut Vec::new());
            (only_fixed.found, two_way.iter().map(|e| e.wire).collect())
        };
        if found.is_empty() {
            out.dropped += all.len();
            continue;
        }
        let undecided = all.iter().filter(|w| open_wires.contains(w)).count();
        out.undecided += undecided;
        out.settled += all.len() - undecided;
        let best = found.iter().map(|f| f.chi2).fold(f64::INFINITY, f64::min);
        let weights: Vec<f64> = found.iter().map(|f| (-(f.chi2 - best) / 2.0).exp()).collect();
        let total: f64 = weights.iter().sum();
        for (&k, &c) in &col {
            let mean = found.iter().zip(&weights).map(|(f, w)| w * f.t[c]).sum::<f64>() / total;
            let variance = found
                .iter()
                .zip(&weights)
                .map(|(f, w)| w * (f.sigma[c].powi(2) + (f.t[c] - mean).powi(2)))
                .sum::<f64>()
                / total;
            out.along[k] = Some((mean, variance.max(0.0).sqrt()));
        }
    }
    out
}

/// The largest misfit (chi-square) of `readings` of `places` that chance
/// explains: a wrong wire pulls the fit toward it, so the whole chain's
/// misfit is judged, not each wire's.
fn chance(readings: usize, places: usize) -> f64 {
    let spare = readings.saturating_sub(places) as f64;
    spare + CONFLICT_SIGMAS * (2.0 * spare).sqrt() + CONFLICT_SIGMAS
}

/// Fits tried per chain before its two-way readings are left out.
const MAX_FITS: usize = 1 << 14;
/// A place no reading touches is taken this uncertain, m: it keeps every
/// partial fit solvable and weighs nothing beside a reading.
const LOOSE_M: f64 = 1.0;

/// One reading of a chain's places, by column.
#[derive(Clone, Copy)]
struct Row {
    a: Option<usize>,
    b: usize,
    step: f64,
    sigma: f64,
}

/// The chain's places under one choice of its two-way readings.
struct Fit {
    t: DVector<f64>,
    sigma: DVector<f64>,
    chi2: f64,
    choice: Vec<usize>,
}

/// A depth-first search over the two-way readings' choices.
struct Search {
    nodes: usize,
    /// Choices whose misfit passes this are not followed (a reading added
    /// never lowers it): beyond chance, or beyond the best found by more
    /// than its sign's exclusion.
    bound: f64,
    /// Fits left to try.
    budget: usize,
    found: Vec<Fit>,
}

impl Search {
    /// Follows every choice of `open` after `rows`; false when the budget ran out.
    fn explore(&mut self, rows: &mut Vec<Row>, open: &[Vec<Row>], choice: &mut Vec<usize>) -> bool {
        if self.budget == 0 {
            return false;
        }
        self.budget -= 1;
        let Some((t, chol)) = fit(self.nodes, rows) else { return true };
        let chi2: f64 = rows.iter().map(|r| ((t[r.b] - r.a.map_or(0.0, |a| t[a]) - r.step) / r.sigma).powi(2)).sum();
        if chi2 > self.bound {
            return true;
        }
        let Some((options, rest)) = open.split_first() else {
            self.bound = self.bound.min(chi2 + EXCLUDE_SIGMAS * EXCLUDE_SIGMAS);
            let sigma = chol.inverse().diagonal().map(|v| v.max(0.0).sqrt());
            self.found.push(Fit { t, sigma, chi2, choice: choice.clone() });
            return true;
        };
        for (k, option) in options.iter().enumerate() {
            rows.push(*option);
            choice.push(k);
            let within = self.explore(rows, rest, choice);
            rows.pop();
            choice.pop();
            if !within {
                return false;
            }
        }
        true
    }
}

/// Weighted least squares of `nodes` places from `rows`.
fn fit(nodes: usize, rows: &[Row]) -> Option<(DVector<f64>, nalgebra::Cholesky<f64, nalgebra::Dyn>)> {
    let mut info = DMatrix::<f64>::identity(nodes, nodes) * LOOSE_M.powi(-2);
    let mut rhs = DVector::<f64>::zeros(nodes);
    for r in rows {
        let w = r.sigma.powi(-2);
        info[(r.b, r.b)] += w;
        rhs[r.b] += w * r.step;
        if let Some(a) = r.a {
            info[(a, a)] += w;
            info[(a, r.b)] -= w;
            info[(r.b, a)] -= w;
            rhs[a] -= w * r.step;
        }
    }
    let chol = info.cholesky()?;
    Some((chol.solve(&rhs), chol))
}

/// `two_way` ordered so each touches the anchor or a place already tied
/// to it (by `fixed` or an earlier one) where it can: a choice is then
/// judged by the loops it closes as soon as it is made, and a wrong one is
/// cut before the choices after it are followed.
fn reached_first<'a>(mut two_way: Vec<&'a Equation>, fixed: &[Row], col: &HashMap<usize, usize>) -> Vec<&'a Equation> {
    let mut reached: Vec<bool> = vec![false; col.len()];
    // Ties `a` and `b`; whether that reached a place not reached before.
    let tie = |a: Option<usize>, b: usize, reached: &mut [bool]| {
        let (at_a, at_b) = (a.is_none_or(|a| reached[a]), reached[b]);
        if at_a || at_b {
            reached[b] = true;
            if let Some(a) = a {
                reached[a] = true;
            }
        }
        (at_a || at_b) && !(at_a && at_b)
    };
    let mut ordered = Vec::new();
    loop {
        while fixed.iter().any(|r| tie(r.a, r.b, &mut reached)) {}
        let next = two_way
            .iter()
            .position(|e| e.a.map(|a| col[&a]).is_none_or(|a| reached[a]) || reached[col[&e.b]])
            .unwrap_or(0);
        if two_way.is_empty() {
            return ordered;
        }
        let e = two_way.remove(next);
        tie(e.a.map(|a| col[&a]), col[&e.b], &mut reached);
        ordered.push(e);
    }
}

/// The chain (lowest node index in it) each node belongs to.
fn chains(nodes: usize, equations: &[Equation]) -> Vec<usize> {
    let mut chain: Vec<usize> = (0..nodes).collect();
    let mut merged = true;
    while merged {
        merged = false;
        for e in equations {
            if let Some(a) = e.a {
                let low = chain[a].min(chain[e.b]);
                if chain[a] != low || chain[e.b] != low {
                    let (old_a, old_b) = (chain[a], chain[e.b]);
                    chain.iter_mut().filter(|c| **c == old_a || **c == old_b).for_each(|c| *c = low);
                    merged = true;
                }
            }
        }
    }
    chain
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;
    use proptest::prelude::*;
    use skin_protocol::message::{Neighbour, Port};

    const P: f64 = 0.025;
    const SIGMA: f64 = 5e-4;

    fn cfg() -> NeighbourConfig {
        NeighbourConfig { pitch_m: P, pitch_tolerance: 0.05, max_sigma_m: 0.005 }
    }

    fn chord(offset: Vector3<f64>, normals: [Vector3<f64>; 2]) -> Chord {
        Chord {
            offset,
            offset_covariance: Matrix3::identity() * SIGMA * SIGMA,
            axis: Vector3::z(),
            normals,
            normal_sigma_rad: MOUNT_SIGMA_RAD,
            across_joint: false,
        }
    }

    /// The one step a wire gives: its pitch's and its tangency's readings
    /// weighed together, as the link's fit weighs them.
    fn known(s: Step) -> Reading {
        let Step::Known { pitch, tangent } = s else { panic!("no single step: {s:?}") };
        tangent.map_or(pitch, |t| {
            let (wp, wt) = (pitch.1.powi(-2), t.1.powi(-2));
            ((wp * pitch.0 + wt * t.0) / (wp + wt), (wp + wt).powf(-0.5))
        })
    }

    #[test]
    fn the_normals_choose_the_pitchs_sign_where_they_lean_on_the_axis() {
        // A chamfer: the surface leans 45 degrees on the axis, the chord runs up it.
        let n = Vector3::new(1.0, 0.0, 1.0).normalize();
        let up = Vector3::new(-1.0, 0.0, 1.0).normalize() * P;
        let (v, s) = known(step(&chord(Vector3::new(up.x, 0.0, 0.0), [n, n]), &cfg()));
        assert!((v - up.z).abs() < 3.0 * s && s < 0.002, "{v} {s} against {}", up.z);
        // Down the chamfer: the other sign.
        let (v, _) = known(step(&chord(Vector3::new(-up.x, 0.0, 0.0), [n, n]), &cfg()));
        assert!((v + up.z).abs() < 0.002, "{v}");
        // The pitch and the tangency together are narrower than the pitch alone.
        let Step::Known { pitch, .. } = step(&chord(Vector3::new(up.x, 0.0, 0.0), [n, n]), &cfg()) else { panic!() };
        assert!(s < pitch.1, "{s} against {}", pitch.1);
    }

    #[test]
    fn normals_square_to_the_axis_leave_the_sign_undecided() {
        // A cylinder about the axis: every normal is square to it, and a
        // neighbour a pitch away could be above or below.
        let (a, b) = (Vector3::x(), Vector3::new(1.0, 0.3, 0.0).normalize());
        let Step::Either { pitch: [plus, minus], tangent: None } =
            step(&chord(Vector3::new(0.0, 0.5 * P, 0.0), [a, b]), &cfg())
        else {
            panic!("the sign decided")
        };
        let s = (P * P - (0.5 * P) * (0.5 * P)).sqrt();
        assert!((plus.0 - s).abs() < plus.1 && (minus.0 + s).abs() < minus.1, "{plus:?} {minus:?} against {s}");
    }

    #[test]
    fn a_neighbour_exactly_on_the_axis_plane_says_little() {
        // The chord's known part is already a pitch long: the step is about
        // zero but the pitch's tolerance lets it be millimetres either way.
        let n = Vector3::x();
        let Step::Known { pitch: (v, s), tangent: None } = step(&chord(Vector3::new(0.0, P, 0.0), [n, n]), &cfg())
        else {
            panic!("no step")
        };
        assert_eq!(v, 0.0);
        assert!(s > 0.003, "{s}: a narrow claim from a chord square to the axis");
        // Leaning normals pin it down.
        let lean = Vector3::new(1.0, 0.0, 1.0).normalize();
        let (v, s) = known(step(&chord(Vector3::new(0.0, P, 0.0), [lean, lean]), &cfg()));
        assert!(v.abs() < 3.0 * s && s < 0.002, "{v} {s}");
    }

    #[test]
    fn a_chord_just_short_of_the_pitch_still_tells_its_step_up_to_the_sign() {
        // The known part 23 mm of a 25 mm pitch: the step is about 10 mm
        // either way, not anywhere within a centimetre of zero.
        let n = Vector3::x();
        let Step::Either { pitch: [plus, minus], tangent: None } =
            step(&chord(Vector3::new(0.0, 0.023, 0.0), [n, n]), &cfg())
        else {
            panic!("{:?}", step(&chord(Vector3::new(0.0, 0.023, 0.0), [n, n]), &cfg()))
        };
        let s = (P * P - 0.023f64.powi(2)).sqrt();
        assert!((plus.0 - s).abs() < plus.1 && (minus.0 + s).abs() < minus.1, "{plus:?} {minus:?} against {s}");
        assert!(plus.1 < 0.005, "{plus:?}");
    }

    #[test]
    fn across_a_joint_the_normals_say_nothing_of_the_step() {
        // The same leaning normals on two links: their surfaces need not meet.
        let n = Vector3::new(1.0, 0.0, 1.0).normalize();
        let up = Vector3::new(-1.0, 0.0, 1.0).normalize() * P;
        let across = Chord { across_joint: true, ..chord(Vector3::new(up.x, 0.0, 0.0), [n, n]) };
        assert!(matches!(step(&across, &cfg()), Step::Either { tangent: None, .. }), "{:?}", step(&across, &cfg()));
    }

    #[test]
    fn a_wire_longer_than_any_pitch_is_impossible() {
        let n = Vector3::new(1.0, 0.0, 1.0).normalize();
        assert_eq!(step(&chord(Vector3::new(0.0, 2.0 * P, 0.0), [n, n]), &cfg()), Step::Impossible);
    }

    proptest! {
        /// On any plane, a true wire's step is never impossible, and every
        /// reading given of it is within five of its claimed standard
        /// deviations (one of the two, for the pitch's sign).
        #[test]
        fn a_true_wire_never_misleads(
            tilt in 0.0f64..1.5, azimuth in 0.0..std::f64::consts::TAU, heading in 0.0..std::f64::consts::TAU, stretch in -1.0f64..1.0,
        ) {
            let n = Rotation3::from_axis_angle(&Vector3::z_axis(), azimuth) * Rotation3::from_axis_angle(&Vector3::y_axis(), tilt) * Vector3::z();
            let e1 = n.cross(&Vector3::x()).try_normalize(1e-9).unwrap_or(Vector3::y());
            let e2 = n.cross(&e1);
            let chord_truth = (e1 * heading.cos() + e2 * heading.sin()) * P * (1.0 + 0.05 * stretch);
            let offset = Vector3::new(chord_truth.x, chord_truth.y, 0.0);
            let within = |(v, s): Reading| (v - chord_truth.z).abs() <= 5.0 * s + 1e-9;
            match step(&chord(offset, [n, n]), &cfg()) {
                Step::Known { pitch, tangent } => {
                    prop_assert!(within(pitch), "pitch {:?} vs {}", pitch, chord_truth.z);
                    prop_assert!(tangent.is_none_or(within), "tangent {:?} vs {}", tangent, chord_truth.z);
                }
                Step::Either { pitch, tangent } => {
                    prop_assert!(pitch.iter().any(|p| within(*p)), "pitch {:?} vs {}", pitch, chord_truth.z);
                    prop_assert!(tangent.is_none_or(within), "tangent {:?} vs {}", tangent, chord_truth.z);
                }
                Step::Impossible => prop_assert!(false, "a true wire called impossible"),
            }
        }
    }

    /// A base, link `a` turned by one joint about z, and link `b` beyond it
    /// (about x, 0.1 m up): cells on `a` are blind along z.
    fn model() -> Model {
        Model::from_urdf_str(
            r#"<robot name="t"><link name="base"/><link name="a"/><link name="b"/>
            <joint name="j1" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 0 1"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint>
            <joint name="j2" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0 0 0.1"/><axis xyz="1 0 0"/><limit lower="-1" upper="1" effort="1" velocity="1"/></joint></robot>"#,
        )
        .unwrap()
    }

    /// A cell at `p` (link frame) facing `n`, blind along z unless `known`.
    fn cell(id: u16, body: usize, p: Vector3<f64>, n: Vector3<f64>, known: bool) -> CellPose {
        let frame = Rotation3::rotation_between(&Vector3::z(), &n).unwrap();
        let position = if known { p } else { Vector3::new(p.x, p.y, 0.0) };
        let covariance =
            if known { Matrix3::identity() } else { Matrix3::new(1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0) };
        CellPose {
            id: Address(id),
            body,
            link: String::new(),
            position,
            frame,
            position_sigma_m: if known { Vector3::repeat(SIGMA) } else { Vector3::new(SIGMA, SIGMA, f64::INFINITY) },
            position_covariance_m2: covariance * SIGMA * SIGMA,
            unobservable: if known { vec![] } else { vec![Vector3::z()] },
            from_neighbours: vec![],
            orientation_sigma_rad: 0.005,
            orientation_observable: true,
            gain: Vector3::repeat(1.0),
            offset_mps2: Vector3::zeros(),
            motion_residual_mps2: 0.0,
            inconsistent: false,
            ambiguous_with: vec![],
        }
    }

    /// Tables wiring each pair on the first free ports of both.
    fn tables(ids: &[u16], wires: &[(u16, u16)]) -> Vec<(Address, NeighbourReport)> {
        let mut t: Vec<(Address, NeighbourReport)> =
            ids.iter().map(|&i| (Address(i), NeighbourReport::default())).collect();
        for &(a, b) in wires {
            let free = |t: &Vec<(Address, NeighbourReport)>, id: u16| {
                let k = t.iter().position(|(i, _)| i.0 == id).unwrap();
                (k, t[k].1.neighbours.iter().position(Option::is_none).unwrap())
            };
            let ((ka, pa), (kb, pb)) = (free(&t, a), free(&t, b));
            t[ka].1.neighbours[pa] = Some(Neighbour { id: Address(b), port: Port::ALL[pb] });
            t[kb].1.neighbours[pb] = Some(Neighbour { id: Address(a), port: Port::ALL[pa] });
        }
        t
    }

    /// Three cells up a chamfer of link `a`, one on `b` a pitch below them
    /// and one on `b` a pitch above.
    fn chamfer() -> (Model, Vec<CellPose>, Vec<Vector3<f64>>) {
        let model = model();
        let (a, b) = (model.link("a").unwrap().body, model.link("b").unwrap().body);
        let n = Vector3::new(1.0, 0.0, 1.0).normalize();
        let up = Vector3::new(-1.0, 0.0, 1.0).normalize() * P;
        let origin = Vector3::new(0.05, 0.0, 0.05);
        let truth: Vec<Vector3<f64>> = (0..3).map(|k| origin + up * f64::from(k)).collect();
        let mut cells: Vec<CellPose> =
            truth.iter().enumerate().map(|(k, p)| cell(k as u16 + 1, a, *p, n, false)).collect();
        // The anchor: a pitch down the chamfer, on `b` (0.1 m up the axis from `a`).
        cells.push(cell(9, b, origin - up - Vector3::new(0.0, 0.0, 0.1), n, true));
        cells.push(cell(10, b, truth[2] + up - Vector3::new(0.0, 0.0, 0.1), n, true));
        (model, cells, truth)
    }

    #[test]
    fn a_chain_anchored_across_the_joint_places_the_whole_patch() {
        let (model, mut cells, truth) = chamfer();
        // Across the joint the pitch alone leaves each anchor's sign open;
        // the chain between them settles it.
        let t = tables(&[1, 2, 3, 9, 10], &[(9, 1), (1, 2), (2, 3), (3, 10)]);
        let r = resolve(&mut cells, &model, &[0.0, 0.0], &t, &cfg());
        assert_eq!((r.cells, r.wires, r.dropped, r.one_sided, r.ambiguous), (3, 4, 0, 0, 0));
        for (c, p) in cells.iter().zip(&truth) {
            let e = (c.position - p).norm();
            let claimed = c.position_sigma_m.norm();
            assert!(c.unobservable.is_empty() && c.from_neighbours == [Vector3::z()], "{c:?}");
            assert!(e < 5.0 * claimed && claimed < 0.004, "cell {}: {e} m off, {claimed} m claimed", c.id.0);
        }
    }

    /// The tables place no cell of the chamfer, leave one sign open and
    /// move nothing.
    fn leaves_one_sign_open(model: &Model, mut cells: Vec<CellPose>, t: &[(Address, NeighbourReport)]) {
        let before = cells.clone();
        let r = resolve(&mut cells, model, &[0.0, 0.0], t, &cfg());
        assert_eq!((r.cells, r.ambiguous), (0, 1), "{r:?}");
        assert_eq!(cells, before);
    }

    #[test]
    fn one_anchor_across_the_joint_leaves_the_sign_open() {
        let (model, cells, _) = chamfer();
        leaves_one_sign_open(&model, cells, &tables(&[1, 2, 3, 9], &[(9, 1), (1, 2), (2, 3)]));
    }

    #[test]
    fn a_step_between_two_links_surfaces_does_not_mislead() {
        // The anchor's surface stands 4 mm proud of the chamfer's: the chord
        // leaves the tangent plane, which a tangency read across the joint
        // took for a step 6 mm off, claimed to 1.4 mm.
        let (model, mut cells, _) = chamfer();
        let n = Vector3::new(1.0, 0.0, 1.0).normalize();
        cells[3].position += n * 0.004;
        leaves_one_sign_open(&model, cells, &tables(&[1, 9], &[(9, 1)]));
    }

    #[test]
    fn two_wires_that_each_leave_the_sign_open_settle_it_together() {
        // A cylinder about the axis (normals square to it): a cell with two
        // neighbours across the joint, 20 mm above and 20 mm below it. Each
        // says "20 mm either way"; only one place fits both.
        let model = model();
        let (a, b) = (model.link("a").unwrap().body, model.link("b").unwrap().body);
        let p = Vector3::new(0.05, 0.0, 0.03);
        let lift = Vector3::new(0.0, 0.0, 0.1);
        let mut cells = vec![
            cell(1, a, p, Vector3::x(), false),
            cell(2, b, p + Vector3::new(0.0, 0.015, 0.02) - lift, Vector3::x(), true),
            cell(3, b, p + Vector3::new(0.0, -0.015, -0.02) - lift, Vector3::x(), true),
        ];
        let r = resolve(&mut cells, &model, &[0.0, 0.0], &tables(&[1, 2], &[(1, 2)]), &cfg());
        assert_eq!((r.cells, r.ambiguous), (0, 1), "one wire: {r:?}");
        let r = resolve(&mut cells, &model, &[0.0, 0.0], &tables(&[1, 2, 3], &[(1, 2), (1, 3)]), &cfg());
        assert_eq!((r.cells, r.wires, r.ambiguous), (1, 2, 0), "{r:?}");
        let (e, claimed) = ((cells[0].position - p).norm(), cells[0].position_sigma_m.norm());
        assert!(e < 3.0 * claimed && claimed < 0.003, "{e} m off, {claimed} m claimed");
    }

    #[test]
    fn neighbours_on_the_same_link_alone_leave_it_unobservable() {
        let (model, mut cells, _) = chamfer();
        let t = tables(&[1, 2, 3, 9], &[(1, 2), (2, 3)]);
        let before = cells.clone();
        let r = resolve(&mut cells, &model, &[0.0, 0.0], &t, &cfg());
        assert_eq!(r.cells, 0);
        assert_eq!(cells, before);
    }

    #[test]
    fn a_one_sided_or_impossible_wire_anchors_nothing() {
        let (model, mut cells, _) = chamfer();
        // The anchor names cell 1, which does not name it back.
        let mut t = tables(&[1, 2, 3, 9], &[(9, 1), (1, 2)]);
        t[0].1.neighbours[0] = None;
        let before = cells.clone();
        let r = resolve(&mut cells, &model, &[0.0, 0.0], &t, &cfg());
        assert_eq!((r.cells, r.one_sided), (0, 1));
        assert_eq!(cells, before);
        // Cell 3 (two pitches from the anchor) wired to it by mistake.
        let t = tables(&[1, 2, 3, 9], &[(9, 3), (1, 2), (2, 3)]);
        let r = resolve(&mut cells, &model, &[0.0, 0.0], &t, &cfg());
        assert_eq!((r.cells, r.dropped), (0, 1));
        assert_eq!(cells, before);
    }

    #[test]
    fn a_wrong_wire_beside_true_ones_is_outvoted_or_dropped() {
        let (model, mut cells, truth) = chamfer();
        // True anchors for cells 1 and 3, and a false one for cell 3: a
        // pitch from it if 12 mm farther up the axis.
        let mut false_anchor = cells[3].clone();
        false_anchor.id = Address(11);
        false_anchor.position = truth[2] + Vector3::new(0.0, 0.015, 0.032) - Vector3::new(0.0, 0.0, 0.1);
        cells.push(false_anchor);
        let t = tables(&[1, 2, 3, 9, 10, 11], &[(9, 1), (1, 2), (2, 3), (3, 10), (11, 3)]);
        let r = resolve(&mut cells, &model, &[0.0, 0.0], &t, &cfg());
        assert!(r.dropped > 0, "{r:?}");
        for (c, p) in cells.iter().zip(&truth).filter(|(c, _)| c.unobservable.is_empty()) {
            let e = (c.position - p).norm();
            assert!(e < 5.0 * c.position_sigma_m.norm() + 0.001, "cell {} confidently {e} m off ({r:?})", c.id.0);
        }
    }
}
