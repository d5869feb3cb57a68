//! The filter's landmark entries (section 2.6, eqs 13–14 and the Euclidean conversion of
//! Civera, Davison and Montiel): landmarks start from one observation at an inverse-depth
//! prior, correlated with the pose that saw them; they leave; and a landmark whose depth is
//! known becomes a Euclidean point of 3 entries instead of 6. Each operation first closes the
//! wheeled model's open step, whose copy of the previous pose sits at the end of the state.

use nalgebra::{DMatrix, DVector, Matrix2, SMatrix, Vector2};

use super::ekf::{symmetric, Filter, Slot, POSE};
use super::inverse_depth::{self, Parametrisation};

impl Filter {
    /// Adds inverse-depth landmarks seen at `pixels` from the current pose, with inverse-depth
    /// prior ρ₀ ± σ_ρ; returns their ids. One reallocation for the whole batch.
    pub fn add_landmarks(
        &mut self,
        pixels: &[Vector2<f64>],
        rho0: f64,
        rho_sigma: f64,
    ) -> Vec<u64> {
        let priors: Vec<(Vector2<f64>, f64, f64)> =
            pixels.iter().map(|&z| (z, rho0, rho_sigma)).collect();
        self.add_landmarks_with_depth(&priors)
    }

    /// Adds inverse-depth landmarks seen from the current pose, each with its own
    /// inverse-depth prior: `(pixel, ρ, σ_ρ)` (a triangulated depth, for instance).
    pub fn add_landmarks_with_depth(&mut self, priors: &[(Vector2<f64>, f64, f64)]) -> Vec<u64> {
        self.close_step(); // Landmark entries move: the step's copy at the end goes first.
        let pixels: Vec<Vector2<f64>> = priors.iter().map(|p| p.0).collect();
        if pixels.is_empty() {
            return Vec::new();
        }
        let n = self.dim();
        let k = pixels.len();
        let n_new = n + 6 * k;
        let r = self.position();
        let q = self.orientation();
        let r_pix = Matrix2::identity() * self.pixel_sigma * self.pixel_sigma;
        let mut x = DVector::zeros(n_new);
        x.rows_mut(0, n).copy_from(&self.x);
        let mut p = DMatrix::zeros(n_new, n_new);
        p.view_mut((0, 0), (n, n)).copy_from(&self.p);
        let pose_rows = self.p.rows(0, POSE).into_owned(); // 7×n
        let ppp = self.p.fixed_view::<7, 7>(0, 0).into_owned();
        let mut jacobians: Vec<SMatrix<f64, 6, 7>> = Vec::with_capacity(k);
        let mut ids = Vec::with_capacity(k);
        for (i, (z, &(_, rho0, rho_sigma))) in pixels.iter().zip(priors).enumerate() {
            let (y, jp, jz) = inverse_depth::initialise(&self.camera, *z, &r, &q, rho0);
            let off = n + 6 * i;
            x.rows_mut(off, 6).copy_from_slice(&y);
            let cross = jp * &pose_rows; // 6×n
            p.view_mut((off, 0), (6, n)).copy_from(&cross);
            p.view_mut((0, off), (n, 6)).copy_from(&cross.transpose());
            let mut pyy = jp * ppp * jp.transpose() + jz * r_pix * jz.transpose();
            pyy[(5, 5)] += rho_sigma * rho_sigma;
            p.view_mut((off, off), (6, 6)).copy_from(&symmetric(&pyy));
            // Landmarks added together are correlated through the shared pose.
            for (j, jp_other) in jacobians.iter().enumerate() {
                let block = jp * ppp * jp_other.transpose();
                let off_j = n + 6 * j;
                p.view_mut((off, off_j), (6, 6)).copy_from(&block);
                p.view_mut((off_j, off), (6, 6))
                    .copy_from(&block.transpose());
            }
            jacobians.push(jp);
            self.slots.push(Slot {
                id: self.next_id,
                kind: Parametrisation::InverseDepth,
                offset: off,
            });
            ids.push(self.next_id);
            self.next_id += 1;
        }
        self.x = x;
        self.p = p;
        ids
    }

    /// Deletes the landmarks whose slot index is in `remove` (any order).
    pub fn remove_landmarks(&mut self, remove: &[usize]) {
        self.close_step(); // Landmark entries move: the step's copy at the end goes first.
        if remove.is_empty() {
            return;
        }
        let c = self.motion.camera_dim();
        let mut keep: Vec<usize> = (0..c).collect();
        let mut slots = Vec::with_capacity(self.slots.len());
        let mut offset = c;
        for (i, s) in self.slots.iter().enumerate() {
            if remove.contains(&i) {
                continue;
            }
            keep.extend(s.offset..s.offset + s.kind.dim());
            slots.push(Slot { offset, ..*s });
            offset += s.kind.dim();
        }
        self.x = self.x.select_rows(&keep);
        self.p = self.p.select_rows(&keep).select_columns(&keep);
        self.slots = slots;
    }

    /// Replaces inverse-depth landmark `slot` by its Euclidean point (3 entries instead of 6).
    pub fn convert_to_euclidean(&mut self, slot: usize) {
        self.close_step(); // Landmark entries move: the step's copy at the end goes first.
        let s = self.slots[slot];
        if s.kind != Parametrisation::InverseDepth || self.landmark(slot)[5] <= 0.0 {
            return;
        }
        let (point, j) = inverse_depth::to_euclidean(self.landmark(slot));
        let n = self.dim();
        let off = s.offset;
        let rows = j * self.p.rows(off, 6); // 3×n
        let pxx = rows.columns(off, 6) * j.transpose();
        // Old indices other than the 6-block, in order; the new block takes `off..off+3`.
        let map = |old: usize| if old < off { old } else { old - 3 };
        let others: Vec<usize> = (0..n).filter(|&i| i < off || i >= off + 6).collect();
        let mut p = DMatrix::zeros(n - 3, n - 3);
        for &cj in &others {
            let nj = map(cj);
            for &ci in &others {
                p[(map(ci), nj)] = self.p[(ci, cj)];
            }
            for a in 0..3 {
                p[(off + a, nj)] = rows[(a, cj)];
                p[(nj, off + a)] = rows[(a, cj)];
            }
        }
        p.view_mut((off, off), (3, 3)).copy_from(&symmetric(&pxx));
        let mut x = DVector::zeros(n - 3);
        for &ci in &others {
            x[map(ci)] = self.x[ci];
        }
        x.rows_mut(off, 3).copy_from(&point);
        self.x = x;
        self.p = p;
        self.slots[slot].kind = Parametrisation::Euclidean;
        for later in &mut self.slots[slot + 1..] {
            later.offset -= 3;
        }
    }
}
