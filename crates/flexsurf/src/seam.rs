//! Seams: boundary edges of panels (of two panels, or two edges of one) joined node to node; a side may be a
//! part of its edge ([`SeamSide::span`]: a sewing pattern's seam between marks), the rest of the edge staying
//! free.
//!
//! A seam makes the nodes of its two edges one: the model numbers the joined nodes once ([`weld`]), so every
//! term that acts on a panel's nodes (membrane, masses, contact, pins, springs) acts on the joined node, and the
//! shares of the two sides simply add (half a stretch edge's weight and half a node's area from each side give
//! the whole, as inside a panel). Bending is the one term whose stencils reach across an edge: a panel leaves
//! the bending points of its seamed edges out ([`SeamedEdges`]) and the seam puts back the points a grid running
//! on across the seam would have ([`seam_bending`]): the nodal curvatures of the seam's nodes with central
//! differences across it and the cells on either side, computed on a strip of five node rows (two of each side
//! and the seam) laid out in side `a`'s parametric directions. So a periodic direction written as a free grid
//! whose first and last node rows are seamed is the periodic grid, up to the order of floating-point sums
//! (`tests/suite/seams.rs`).
//!
//! What stays approximate: the strip takes side `a`'s grid spacing and material frame on both sides (exact when
//! both sides are one grid, as for a closed panel); where the rest positions of the two edges differ (flat
//! pieces sewn together) side `b`'s rows are turned rigidly so that they continue `a` flat across the seam;
//! at a corner where two seams meet, a cell on both is counted once and the corner node carries each seam's
//! curvature across it.

use crate::energy::bending::Bending;
use crate::energy::frame::Warp;
use crate::grid::{Grid, Topology};
use crate::material::Stiffness;
use crate::math::Vec3;
use serde::{Deserialize, Serialize};
use std::collections::BTreeSet;

/// A boundary edge of a panel's grid, named by the direction it closes and its end.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[cfg_attr(feature = "app", derive(schemars::JsonSchema))]
pub enum Edge {
    /// The nodes `(0, j)`, `j` increasing.
    U1Start,
    /// The nodes `(M − 1, j)`, `j` increasing.
    U1End,
    /// The nodes `(i, 0)`, `i` increasing.
    U2Start,
    /// The nodes `(i, N − 1)`, `i` increasing.
    U2End,
}

impl Edge {
    /// The direction across the edge (0 = u1, 1 = u2).
    pub fn across(self) -> usize {
        match self {
            Edge::U1Start | Edge::U1End => 0,
            Edge::U2Start | Edge::U2End => 1,
        }
    }

    /// True for the edge at the end of its direction.
    pub fn at_end(self) -> bool {
        matches!(self, Edge::U1End | Edge::U2End)
    }

    /// Number of nodes along the edge.
    pub fn count(self, grid: &Grid) -> usize {
        grid.count(1 - self.across())
    }

    /// The local node `depth` rows inside the edge (0: on it) at position `t` along it.
    pub fn node(self, grid: &Grid, t: usize, depth: usize) -> usize {
        let d = self.across();
        let row = if self.at_end() { grid.count(d) - 1 - depth } else { depth };
        if d == 0 {
            grid.index(row, t)
        } else {
            grid.index(t, row)
        }
    }
}

/// One side of a seam: an edge of a panel, run along in its own order or reversed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct SeamSide {
    /// The panel (index in the model's panels).
    pub panel: usize,
    /// Its edge.
    pub edge: Edge,
    /// The edge runs the other way along the seam (its last node is joined to the other side's first).
    #[serde(default)]
    pub reversed: bool,
    /// The part of the edge that is sewn: its nodes `span[0] ..= span[1]` in the edge's own order; `None`: the
    /// whole edge.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub span: Option<[usize; 2]>,
}

impl SeamSide {
    /// The whole `edge` of `panel`.
    pub fn whole(panel: usize, edge: Edge, reversed: bool) -> Self {
        Self { panel, edge, reversed, span: None }
    }

    /// The sewn nodes' first and last positions along the edge (its own order).
    pub fn range(&self, grid: &Grid) -> [usize; 2] {
        self.span.unwrap_or([0, self.edge.count(grid).saturating_sub(1)])
    }

    /// Number of sewn nodes.
    pub fn len(&self, grid: &Grid) -> usize {
        let [lo, hi] = self.range(grid);
        hi + 1 - lo.min(hi + 1)
    }

    /// Local node of this side at position `t` of `len` along the seam, `depth` rows inside.
    pub fn node(&self, grid: &Grid, t: usize, len: usize, depth: usize) -> usize {
        let [lo, _] = self.range(grid);
        self.edge.node(grid, lo + if self.reversed { len - 1 - t } else { t }, depth)
    }
}

/// Two edges joined node to node: the `t`-th node of `a` and of `b` (each in its own direction) become one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Seam {
    /// The first side; the seam's own bending points take its grid spacing and material frame.
    pub a: SeamSide,
    /// The second side.
    pub b: SeamSide,
}

/// Which parts of the boundary edges of one panel are seamed: `[direction][0 = start, 1 = end]`, each a list of
/// sewn node ranges `[first, last]` along the edge (a whole edge: `[0, count − 1]`).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct SeamedEdges(pub [[Vec<[usize; 2]>; 2]; 2]);

impl SeamedEdges {
    /// The seamed edges of panel `p` (whose grid is `grid`).
    pub fn of(p: usize, grid: &Grid, seams: &[Seam]) -> Self {
        let mut e = Self::default();
        for side in seams.iter().flat_map(|s| [s.a, s.b]).filter(|s| s.panel == p) {
            e.0[side.edge.across()][usize::from(side.edge.at_end())].push(side.range(grid));
        }
        e
    }

    /// The ranges along the edge across direction `d` at row `c` (none unless `c` is a boundary row).
    fn at_row<'a>(&'a self, grid: &'a Grid, d: usize, c: usize) -> impl Iterator<Item = &'a [usize; 2]> + 'a {
        let start = self.0[d][0].iter().filter(move |_| c == 0);
        start.chain(self.0[d][1].iter().filter(move |_| c + 1 == grid.count(d)))
    }

    /// True when node `k` of `grid` lies on a seamed part of an edge.
    pub fn holds_node(&self, grid: &Grid, k: usize) -> bool {
        let (i, j) = grid.coords(k);
        [(0, i, j), (1, j, i)].iter().any(|&(d, c, t)| self.at_row(grid, d, c).any(|&[lo, hi]| (lo..=hi).contains(&t)))
    }

    /// True when cell `(i, j)` of `grid` has two corners on one seamed part of an edge (for a whole edge: a
    /// corner on it).
    pub fn holds_cell(&self, grid: &Grid, i: usize, j: usize) -> bool {
        [(0, i, j), (1, j, i)].iter().any(|&(d, c, t)| {
            [c, c + 1].into_iter().any(|r| self.at_row(grid, d, r).any(|&[lo, hi]| lo <= t && t < hi))
        })
    }
}

/// A seam that cannot be made: which seam and what is wrong.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("seam {seam}: {message}")]
pub struct SeamError {
    /// Index of the seam.
    pub seam: usize,
    /// What is wrong.
    pub message: String,
}

/// The model's numbering of the panels' nodes once the seams are joined.
#[derive(Debug, Clone, PartialEq)]
pub struct Welds {
    /// Per panel, the model node of each local node.
    pub maps: Vec<Vec<usize>>,
    /// Number of model nodes.
    pub nodes: usize,
}

/// Checks one side of seam `s` against the panels' grids.
fn check_side(s: usize, side: &SeamSide, grids: &[Grid]) -> Result<(), SeamError> {
    let bad = |message: String| SeamError { seam: s, message };
    let grid = grids.get(side.panel).ok_or_else(|| bad(format!("panel {} does not exist", side.panel)))?;
    if grid.periodic(side.edge.across()) {
        return Err(bad(format!("panel {} is periodic across {:?}: that edge does not exist", side.panel, side.edge)));
    }
    Ok(())
}

/// The root of `k` in a union-find forest (by the smallest index).
fn root(parent: &mut [usize], mut k: usize) -> usize {
    while parent[k] != k {
        parent[k] = parent[parent[k]];
        k = parent[k];
    }
    k
}

/// Joins the seams' nodes: the model numbers the panels' nodes panel after panel, a node joined to an earlier
/// one taking that one's number. Without seams, panel `p`'s node `k` is `Σ_{q<p} len_q + k`.
pub fn weld(grids: &[Grid], seams: &[Seam]) -> Result<Welds, SeamError> {
    let starts: Vec<usize> = grids.iter().scan(0, |o, g| Some(std::mem::replace(o, *o + g.len()))).collect();
    let total: usize = grids.iter().map(Grid::len).sum();
    let mut parent: Vec<usize> = (0..total).collect();
    for (s, seam) in seams.iter().enumerate() {
        check_side(s, &seam.a, grids)?;
        check_side(s, &seam.b, grids)?;
        let (ga, gb) = (&grids[seam.a.panel], &grids[seam.b.panel]);
        for side in [&seam.a, &seam.b] {
            let [lo, hi] = side.range(&grids[side.panel]);
            if lo >= hi || hi >= side.edge.count(&grids[side.panel]) {
                let message =
                    format!("its span {lo} ..= {hi} of panel {} {:?} is not within the edge", side.panel, side.edge);
                return Err(SeamError { seam: s, message });
            }
        }
        let (la, lb) = (seam.a.len(ga), seam.b.len(gb));
        if la != lb {
            let message = format!(
                "its edges have {la} and {lb} nodes (panel {} {:?}, panel {} {:?}); a seam joins equal counts",
                seam.a.panel, seam.a.edge, seam.b.panel, seam.b.edge
            );
            return Err(SeamError { seam: s, message });
        }
        if la < 3 {
            // The seam's bending strip has rows along the seam, whose second differences need three nodes.
            let message = format!(
                "its edges have {la} nodes (panel {} {:?}, panel {} {:?}); a seam needs 3 or more: a finer grid (a smaller edge_length)",
                seam.a.panel, seam.a.edge, seam.b.panel, seam.b.edge
            );
            return Err(SeamError { seam: s, message });
        }
        if seam.a.panel == seam.b.panel && seam.a.edge == seam.b.edge && seam.a.span == seam.b.span {
            return Err(SeamError { seam: s, message: "it joins an edge to itself".into() });
        }
        for t in 0..la {
            let p = root(&mut parent, starts[seam.a.panel] + seam.a.node(ga, t, la, 0));
            let q = root(&mut parent, starts[seam.b.panel] + seam.b.node(gb, t, lb, 0));
            parent[p.max(q)] = p.min(q);
        }
    }
    let mut number = vec![usize::MAX; total];
    let mut nodes = 0;
    for k in 0..total {
        let r = root(&mut parent, k);
        number[k] = if r == k { (nodes, nodes += 1).0 } else { number[r] };
    }
    let maps: Vec<Vec<usize>> = grids.iter().zip(&starts).map(|(g, &o)| number[o..o + g.len()].to_vec()).collect();
    check_cells(grids, &maps)?;
    Ok(Welds { maps, nodes })
}

/// Every cell keeps four distinct corners (a seam that joins two corners of one cell folds it).
fn check_cells(grids: &[Grid], maps: &[Vec<usize>]) -> Result<(), SeamError> {
    for (p, (grid, map)) in grids.iter().zip(maps).enumerate() {
        for (i, j) in grid.cells() {
            let c = grid.cell(i, j).map(|k| map[k]);
            if (0..4).any(|a| (a + 1..4).any(|b| c[a] == c[b])) {
                let message = format!("the seams join two corners of cell ({i}, {j}) of panel {p}");
                return Err(SeamError { seam: 0, message });
            }
        }
    }
    Ok(())
}

/// One panel as the seam's strip sees it.
pub struct PanelView<'a> {
    /// The grid.
    pub grid: &'a Grid,
    /// Rest shape, in the grid's node order.
    pub rest: &'a [Vec3],
    /// Model node of each local node.
    pub map: &'a [usize],
}

/// The strip of five rows across seam `seam`: its grid (side `a`'s directions and spacings), the rest
/// positions and the model node of each strip node.
fn strip(seam: &Seam, panels: &[PanelView<'_>]) -> (Grid, Vec<Vec3>, Vec<usize>) {
    let (pa, pb) = (&panels[seam.a.panel], &panels[seam.b.panel]);
    let d = seam.a.edge.across();
    let len = seam.a.len(pa.grid);
    let h = [pa.grid.spacing(0), pa.grid.spacing(1)];
    let (m, n) = if d == 0 { (5, len) } else { (len, 5) };
    let grid = Grid::new(m, n, h[0], h[1], [Topology::Free; 2]).expect("a strip of valid spacings");
    let b_rest = aligned_rest(seam, pa, pb, len);
    let (mut rest, mut map) = (vec![Vec3::ZERO; grid.len()], vec![0; grid.len()]);
    for t in 0..len {
        for c in 0..5 {
            // Rows across the seam in a's increasing direction: a's side below the seam row 2 when a's
            // edge is its end, above it when its start.
            let depth = (c as isize - 2).unsigned_abs();
            let on_a = c == 2 || ((c < 2) == seam.a.edge.at_end());
            let (x, g) = if on_a {
                let k = seam.a.node(pa.grid, t, len, depth);
                (pa.rest[k], pa.map[k])
            } else {
                let k = seam.b.node(pb.grid, t, len, depth);
                (b_rest(k), pb.map[k])
            };
            let s = if d == 0 { grid.index(c, t) } else { grid.index(t, c) };
            rest[s] = x;
            map[s] = g;
        }
    }
    (grid, rest, map)
}

/// Side `b`'s rest positions as the strip uses them: as they are where its edge lies on side `a`'s (a closed
/// panel, pieces given in place), else turned rigidly so that `b`'s edge lies on `a`'s and `b` continues `a`
/// flat across it (two flat pieces).
fn aligned_rest<'a>(
    seam: &Seam,
    pa: &'a PanelView<'_>,
    pb: &'a PanelView<'_>,
    len: usize,
) -> impl Fn(usize) -> Vec3 + 'a {
    let edge = |side: &SeamSide, p: &PanelView<'_>, depth: usize| -> Vec<Vec3> {
        (0..len).map(|t| p.rest[side.node(p.grid, t, len, depth)]).collect()
    };
    let (ea, eb) = (edge(&seam.a, pa, 0), edge(&seam.b, pb, 0));
    let scale = ea.iter().zip(&ea[1..]).map(|(p, q)| (*q - *p).length()).sum::<f64>().max(f64::MIN_POSITIVE);
    let apart = ea.iter().zip(&eb).map(|(p, q)| (*q - *p).length()).fold(0.0, f64::max);
    let frame = |e: &[Vec3], inner: &[Vec3]| -> (Vec3, [Vec3; 3]) {
        let o = e.iter().copied().sum::<Vec3>() / len as f64;
        let u = (e[len - 1] - e[0]).normalize_or_zero();
        let w = inner.iter().zip(e).map(|(i, p)| *i - *p).sum::<Vec3>();
        let w = (w - u * u.dot(w)).normalize_or_zero();
        (o, [u, w, u.cross(w)])
    };
    let (oa, fa) = frame(&ea, &edge(&seam.a, pa, 1));
    let (ob, fb) = frame(&eb, &edge(&seam.b, pb, 1));
    let turn = apart > 1e-9 * scale;
    move |k: usize| {
        let x = pb.rest[k];
        if !turn {
            return x;
        }
        // b's (along, inward, normal) onto a's (along, outward, −normal): a proper rotation.
        let r = x - ob;
        let (c0, c1, c2) = (r.dot(fb[0]), r.dot(fb[1]), r.dot(fb[2]));
        oa + fa[0] * c0 - fa[1] * c1 - fa[2] * c2
    }
}

/// One seam's strip of five node rows (two of each side and the seam, laid out in side `a`'s parametric
/// directions) with what of it the seam puts back: the nodes of its middle row and the cells next to it that no
/// earlier seam took.
#[derive(Debug, Clone)]
pub struct SeamStrip {
    /// The strip's grid and rest positions.
    pub grid: Grid,
    /// Rest positions of the strip's nodes.
    pub rest: Vec<Vec3>,
    /// The model's node of each strip node.
    pub map: Vec<usize>,
    /// The cells the seam puts back.
    pub cells: BTreeSet<(usize, usize)>,
    /// Side `a`'s panel (whose frame the strip takes).
    pub panel: usize,
    across: usize,
}

impl SeamStrip {
    /// Whether strip node `k` is on the seam (the strip's middle row).
    pub fn holds_node(&self, k: usize) -> bool {
        let (i, j) = self.grid.coords(k);
        (if self.across == 0 { i } else { j }) == 2
    }
}

/// The strips of `seams` in order; a cell on two seams is taken by the first.
pub fn seam_strips(seams: &[Seam], panels: &[PanelView<'_>]) -> Vec<SeamStrip> {
    let mut taken = BTreeSet::new();
    seams
        .iter()
        .map(|seam| {
            let (grid, rest, map) = strip(seam, panels);
            let d = seam.a.edge.across();
            let cell_row = |i: usize, j: usize| if d == 0 { i } else { j };
            let mut keep = |i: usize, j: usize| {
                let mut corners = grid.cell(i, j).map(|k| map[k]);
                corners.sort_unstable();
                (1..=2).contains(&cell_row(i, j)) && taken.insert(corners)
            };
            let cells: BTreeSet<(usize, usize)> = grid.cells().filter(|&(i, j)| keep(i, j)).collect();
            SeamStrip { grid, rest, map, cells, panel: seam.a.panel, across: d }
        })
        .collect()
}

/// The bending points the seams put back: for each seam, the nodal points of its nodes and the cell points of
/// the cells on either side, on the seam's strip ([`seam_strips`]) with side `a`'s stiffness frame `warp`
/// (`flat` sets the rest curvature to zero, as for a garment's flat pattern), numbered as the model's nodes. A
/// cell on two seams is taken once.
pub fn seam_bending(
    seams: &[Seam],
    panels: &[PanelView<'_>],
    s: &Stiffness,
    warp: impl Fn(usize) -> (Warp, bool),
) -> Bending {
    let parts = seam_strips(seams, panels)
        .into_iter()
        .map(|st| {
            let (w, flat) = warp(st.panel);
            let mut b =
                Bending::selected(&st.grid, &st.rest, s, w, |k| st.holds_node(k), |i, j| st.cells.contains(&(i, j)));
            if flat {
                b.flatten_rest_curvature();
            }
            b.map_nodes(&st.map);
            b
        })
        .collect();
    Bending::joined(parts)
}
