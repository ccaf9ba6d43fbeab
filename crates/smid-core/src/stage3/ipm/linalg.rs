//! The linear algebra of the interior-point method: dense Cholesky factors of the small
//! blocks, the banded factor of the equalities' Schur complement, and compressed sparse rows.
use super::SparseRow;

/// Dense Cholesky in place (lower triangle, row-major `n × n`), the diagonal stored as its
/// reciprocal; `false` if not positive.
pub(super) fn chol(a: &mut [f64], n: usize) -> bool {
    for j in 0..n {
        let mut d = a[j * n + j];
        for k in 0..j {
            d -= a[j * n + k] * a[j * n + k];
        }
        if !(d > 0.0) {
            return false;
        }
        let inv = 1.0 / d.sqrt();
        a[j * n + j] = inv;
        for i in j + 1..n {
            let mut s = a[i * n + j];
            for k in 0..j {
                s -= a[i * n + k] * a[j * n + k];
            }
            a[i * n + j] = s * inv;
        }
    }
    true
}

/// Solve `L Lᵀ x = b` in place with a factor from [`chol`] (blocks are small: the common sizes
/// get their own copy with the size a constant, so the loops unroll; same arithmetic).
pub(super) fn chol_solve(l: &[f64], n: usize, b: &mut [f64]) {
    match n {
        1 => chol_solve_inline(l, 1, b),
        2 => chol_solve_inline(l, 2, b),
        3 => chol_solve_inline(l, 3, b),
        4 => chol_solve_inline(l, 4, b),
        5 => chol_solve_inline(l, 5, b),
        6 => chol_solve_inline(l, 6, b),
        _ => chol_solve_inline(l, n, b),
    }
}

#[inline(always)]
fn chol_solve_inline(l: &[f64], n: usize, b: &mut [f64]) {
    let (l, b) = (&l[..n * n], &mut b[..n]);
    for i in 0..n {
        let mut s = b[i];
        for k in 0..i {
            s -= l[i * n + k] * b[k];
        }
        b[i] = s * l[i * n + i];
    }
    for i in (0..n).rev() {
        let mut s = b[i];
        for k in i + 1..n {
            s -= l[k * n + i] * b[k];
        }
        b[i] = s * l[i * n + i];
    }
}

/// A symmetric band matrix, lower band stored per row: `band[r * (w + 1) + k] = M[r][r - k]`.
pub(super) struct Band {
    pub(super) n: usize,
    pub(super) w: usize,
    pub(super) a: Vec<f64>,
}

impl Band {
    pub(super) fn at(&mut self, r: usize, c: usize) -> &mut f64 {
        let (r, c) = if r >= c { (r, c) } else { (c, r) };
        &mut self.a[r * (self.w + 1) + (r - c)]
    }
    /// Cholesky in place, the diagonal stored as its reciprocal; `false` if not positive
    /// definite.
    pub(super) fn factor(&mut self) -> bool {
        let w = self.w;
        let s = w + 1;
        for j in 0..self.n {
            let k0 = j.saturating_sub(w);
            let mut d = self.a[j * s];
            for k in k0..j {
                let l = self.a[j * s + (j - k)];
                d -= l * l;
            }
            if !(d > 0.0) {
                return false;
            }
            let inv = 1.0 / d.sqrt();
            self.a[j * s] = inv;
            for i in j + 1..(j + w + 1).min(self.n) {
                let mut v = self.a[i * s + (i - j)];
                let k0 = i.saturating_sub(w);
                for k in k0..j {
                    v -= self.a[i * s + (i - k)] * self.a[j * s + (j - k)];
                }
                self.a[i * s + (i - j)] = v * inv;
            }
        }
        true
    }
    pub(super) fn solve(&self, b: &mut [f64]) {
        let (w, s) = (self.w, self.w + 1);
        let b = &mut b[..self.n];
        for i in 0..self.n {
            let mut v = b[i];
            for k in i.saturating_sub(w)..i {
                v -= self.a[i * s + (i - k)] * b[k];
            }
            b[i] = v * self.a[i * s];
        }
        for i in (0..self.n).rev() {
            let mut v = b[i];
            for k in i + 1..(i + w + 1).min(self.n) {
                v -= self.a[k * s + (k - i)] * b[k];
            }
            b[i] = v * self.a[i * s];
        }
    }
}

/// Rows stored flat: row `i` is `ent[ptr[i]..ptr[i + 1]]`.
#[derive(Debug, Clone, Default)]
pub(super) struct Csr {
    ptr: Vec<usize>,
    ent: Vec<(usize, f64)>,
}

impl Csr {
    pub(super) fn from_rows(rows: Vec<SparseRow>) -> Self {
        let mut c = Csr {
            ptr: Vec::with_capacity(rows.len() + 1),
            ent: Vec::with_capacity(rows.iter().map(|r| r.len()).sum()),
        };
        c.ptr.push(0);
        for r in rows {
            c.ent.extend(r);
            c.ptr.push(c.ent.len());
        }
        c
    }
    pub(super) fn len(&self) -> usize {
        self.ptr.len() - 1
    }
    pub(super) fn row(&self, i: usize) -> &[(usize, f64)] {
        &self.ent[self.ptr[i]..self.ptr[i + 1]]
    }
    pub(super) fn iter(&self) -> impl Iterator<Item = &[(usize, f64)]> {
        (0..self.len()).map(move |i| self.row(i))
    }
}
