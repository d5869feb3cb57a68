//! The radius queries of the merge (section 2.2.2): a uniform grid over a fixed set of
//! points, and the points of each detection scale in their own grid, so that a query reaches
//! only the scales a merge joins (the adjacent ones, or every one for the pixel merge).

use super::config::MergeMode;
use super::harris::HarrisPlan;

/// A uniform grid over a fixed set of points for radius queries, stored compactly (the
/// points of cell c are `items[start[c]..start[c + 1]]`).
pub(crate) struct Grid {
    cell: f32,
    cols: usize,
    rows: usize,
    start: Vec<u32>,
    items: Vec<u32>,
}

impl Grid {
    pub(crate) fn new(points: &[(f32, f32)], cell: f32) -> Self {
        let (mut mx, mut my) = (0.0f32, 0.0f32);
        for &(x, y) in points {
            mx = mx.max(x);
            my = my.max(y);
        }
        let cols = (mx / cell) as usize + 2;
        let rows = (my / cell) as usize + 2;
        let mut g = Self {
            cell,
            cols,
            rows,
            start: vec![0; cols * rows + 1],
            items: vec![0; points.len()],
        };
        let cells: Vec<usize> = points.iter().map(|&p| g.bucket(p)).collect();
        for &c in &cells {
            g.start[c + 1] += 1;
        }
        for c in 0..cols * rows {
            g.start[c + 1] += g.start[c];
        }
        let mut fill = g.start.clone();
        for (i, &c) in cells.iter().enumerate() {
            g.items[fill[c] as usize] = i as u32;
            fill[c] += 1;
        }
        g
    }
    fn coords(&self, (x, y): (f32, f32)) -> (usize, usize) {
        let cx = ((x.max(0.0) / self.cell) as usize).min(self.cols - 1);
        let cy = ((y.max(0.0) / self.cell) as usize).min(self.rows - 1);
        (cx, cy)
    }
    fn bucket(&self, p: (f32, f32)) -> usize {
        let (cx, cy) = self.coords(p);
        cy * self.cols + cx
    }
    /// Calls `f` with the indices stored in the 3×3 cells around `p` (every point within
    /// `cell` of it among them) until it returns true; whether one did. Plain loops: the
    /// merge's queries are its inner loop.
    #[inline]
    pub(crate) fn any_near(&self, p: (f32, f32), mut f: impl FnMut(usize) -> bool) -> bool {
        let (cx, cy) = self.coords(p);
        let (x0, x1) = (cx.saturating_sub(1), (cx + 1).min(self.cols - 1));
        for y in cy.saturating_sub(1)..=(cy + 1).min(self.rows - 1) {
            // Cells x0..=x1 of one grid row are contiguous in `items`.
            let (a, b) = (
                self.start[y * self.cols + x0] as usize,
                self.start[y * self.cols + x1 + 1] as usize,
            );
            if self.items[a..b].iter().any(|&i| f(i as usize)) {
                return true;
            }
        }
        false
    }
}

/// Squared distance between two points.
pub(crate) fn dist2(a: (f32, f32), b: (f32, f32)) -> f32 {
    (a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)
}

/// Points grouped by detection scale, one [`Grid`] per scale, for the scale-covariant radius
/// queries of the merge: two detections are neighbours when their scales are adjacent (or
/// equal) and they lie within a radius proportional to the larger of their scales. The pixel
/// merge, whose radius is one at every scale and whose queries reach every scale, keeps all the
/// points in one grid instead (a third of the cells visited with its three scales).
pub(crate) struct ScaleGrids {
    /// Per scale (or one for all, with the pixel merge): the grid and the global index of each
    /// of its points.
    grids: Vec<Option<(Grid, Vec<usize>)>>,
    /// Scales on either side a query reaches; `None` when one grid holds every scale.
    span: Option<usize>,
}

impl ScaleGrids {
    /// `cell(s)` must be at least the largest radius a query of scale s ± 1 asks at scale s.
    pub(crate) fn new(
        points: &[(f32, f32)],
        scales: &[usize],
        plan: &HarrisPlan,
        cell: impl Fn(usize) -> f32,
    ) -> Self {
        let count = plan.scales.len();
        if plan.config.merge == MergeMode::Pixel {
            let widest = (0..count).map(&cell).fold(0.0f32, f32::max);
            let grid = (!points.is_empty())
                .then(|| (Grid::new(points, widest), (0..points.len()).collect()));
            return Self {
                grids: vec![grid],
                span: None,
            };
        }
        let mut members: Vec<Vec<usize>> = vec![Vec::new(); count];
        for (i, &s) in scales.iter().enumerate() {
            members[s].push(i);
        }
        let grids = members
            .into_iter()
            .enumerate()
            .map(|(s, members)| {
                if members.is_empty() {
                    return None;
                }
                let pts: Vec<(f32, f32)> = members.iter().map(|&i| points[i]).collect();
                Some((Grid::new(&pts, cell(s)), members))
            })
            .collect();
        Self {
            grids,
            span: Some(1),
        }
    }

    /// Calls `f` with the global indices of the points of scales s − span … s + span (of every
    /// scale, with one grid) in the cells around `p` until it returns true; whether one did.
    pub(crate) fn any_near(
        &self,
        p: (f32, f32),
        s: usize,
        mut f: impl FnMut(usize) -> bool,
    ) -> bool {
        let last = self.grids.len() - 1;
        let scales = match self.span {
            Some(span) => s.saturating_sub(span)..=(s.saturating_add(span)).min(last),
            None => 0..=0,
        };
        scales.into_iter().any(|t| {
            self.grids[t]
                .as_ref()
                .is_some_and(|(g, members)| g.any_near(p, |k| f(members[k])))
        })
    }

    /// Calls `f` with every global index [`Self::any_near`] would visit.
    pub(crate) fn for_each_near(&self, p: (f32, f32), s: usize, mut f: impl FnMut(usize)) {
        self.any_near(p, s, |j| {
            f(j);
            false
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_finds_every_point_within_a_cell() {
        let mut rng = crate::rng::Rng(3);
        let pts: Vec<(f32, f32)> = (0..2000)
            .map(|_| (rng.range(0.0, 300.0), rng.range(0.0, 200.0)))
            .collect();
        let grid = Grid::new(&pts, 3.0);
        for q in pts.iter().step_by(7) {
            let mut found: Vec<usize> = Vec::new();
            grid.any_near(*q, |i| {
                if dist2(pts[i], *q) <= 9.0 {
                    found.push(i);
                }
                false
            });
            found.sort_unstable();
            let expected: Vec<usize> = (0..pts.len())
                .filter(|&i| dist2(pts[i], *q) <= 9.0)
                .collect();
            assert_eq!(found, expected);
        }
    }
}
