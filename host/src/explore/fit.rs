//! Least squares on a DoF's own motion.
//!
//! While one DoF moves, a cell's acceleration is a sum of terms whose time
//! course the host knows from position feedback: the turning gravity
//! follows the position, the tangential term (equation 1) the angular
//! acceleration and the centripetal term (equation 2) the squared velocity.
//! Fitting every axis on those regressors separates the terms instead of
//! neglecting some; the regressors are shared by all cells and axes, so
//! the normal matrix is inverted once per trace.

/// A least-squares fit on `N` regressors sampled at every tick.
pub(crate) struct LeastSquares<const N: usize> {
    rows: Vec<[f64; N]>,
    inverse: [[f64; N]; N],
}

impl<const N: usize> LeastSquares<N> {
    /// A fit on `rows` (one regressor vector per tick); `None` when the
    /// regressors are (nearly) collinear, e.g. a DoF that did not move.
    pub fn new(rows: Vec<[f64; N]>) -> Option<Self> {
        let mut normal = [[0.0; N]; N];
        for x in &rows {
            for i in 0..N {
                for j in 0..N {
                    normal[i][j] += x[i] * x[j];
                }
            }
        }
        Some(LeastSquares { inverse: invert(normal)?, rows })
    }

    /// Coefficients for the samples `y`, one per row; `None` if a sample
    /// is missing (not finite).
    pub fn fit(&self, y: impl Iterator<Item = f64>) -> Option<[f64; N]> {
        let mut xy = [0.0; N];
        for (x, v) in self.rows.iter().zip(y) {
            if !v.is_finite() {
                return None;
            }
            for (s, xi) in xy.iter_mut().zip(x) {
                *s += xi * v;
            }
        }
        Some(std::array::from_fn(|i| (0..N).map(|j| self.inverse[i][j] * xy[j]).sum()))
    }

    /// Coefficients for the samples `y` and the standard error of each,
    /// from the residual variance; `None` if a sample is missing or there
    /// are no more samples than regressors.
    pub fn fit_with_errors(&self, y: &[f64]) -> Option<([f64; N], [f64; N])> {
        if y.len() <= N {
            return None;
        }
        let c = self.fit(y.iter().copied())?;
        let rss: f64 = self
            .rows
            .iter()
            .zip(y)
            .map(|(x, v)| {
                let r = v - x.iter().zip(&c).map(|(xi, ci)| xi * ci).sum::<f64>();
                r * r
            })
            .sum();
        let var = rss / (y.len() - N) as f64;
        Some((c, std::array::from_fn(|i| (var * self.inverse[i][i].max(0.0)).sqrt())))
    }

    /// Variance of coefficient `i` per unit sample variance.
    pub fn variance_factor(&self, i: usize) -> f64 {
        self.inverse[i][i]
    }
}

/// Gauss-Jordan inversion with partial pivoting; `None` if singular
/// relative to the matrix's scale.
fn invert<const N: usize>(mut m: [[f64; N]; N]) -> Option<[[f64; N]; N]> {
    if !m.iter().flatten().all(|x| x.is_finite()) {
        return None;
    }
    let scale = m.iter().flatten().fold(0.0f64, |a, x| a.max(x.abs()));
    if scale == 0.0 {
        return None;
    }
    let mut inv: [[f64; N]; N] = std::array::from_fn(|i| std::array::from_fn(|j| f64::from(u8::from(i == j))));
    for col in 0..N {
        let pivot = (col..N).max_by(|&a, &b| m[a][col].abs().total_cmp(&m[b][col].abs()))?;
        if m[pivot][col].abs() <= 1e-12 * scale {
            return None;
        }
        m.swap(col, pivot);
        inv.swap(col, pivot);
        let p = m[col][col];
        for j in 0..N {
            m[col][j] /= p;
            inv[col][j] /= p;
        }
        for r in 0..N {
            if r != col {
                let f = m[r][col];
                for j in 0..N {
                    m[r][j] -= f * m[col][j];
                    inv[r][j] -= f * inv[col][j];
                }
            }
        }
    }
    Some(inv)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn recovers_the_coefficients_of_an_exact_sum() {
        let rows: Vec<[f64; 3]> = (0..50).map(|k| f64::from(k) * 0.1).map(|t| [1.0, t.sin(), t * t]).collect();
        let fit = LeastSquares::new(rows.clone()).unwrap();
        let y = rows.iter().map(|x| 2.0 - 3.0 * x[1] + 0.5 * x[2]);
        let c = fit.fit(y).unwrap();
        assert!((c[0] - 2.0).abs() < 1e-9 && (c[1] + 3.0).abs() < 1e-9 && (c[2] - 0.5).abs() < 1e-9, "{c:?}");
        assert!(fit.variance_factor(1) > 0.0);
        assert_eq!(fit.fit(rows.iter().map(|_| f64::NAN)), None);
        // An exact sum has no residual, so no error; noise gives some.
        let exact: Vec<f64> = rows.iter().map(|x| 2.0 - 3.0 * x[1] + 0.5 * x[2]).collect();
        let (_, errors) = fit.fit_with_errors(&exact).unwrap();
        assert!(errors.iter().all(|e| *e < 1e-6), "{errors:?}");
        let noisy: Vec<f64> = exact.iter().enumerate().map(|(k, v)| v + if k % 2 == 0 { 0.1 } else { -0.1 }).collect();
        let (_, errors) = fit.fit_with_errors(&noisy).unwrap();
        assert!(errors.iter().all(|e| *e > 1e-4 && e.is_finite()), "{errors:?}");
    }

    #[test]
    fn collinear_or_empty_regressors_are_refused() {
        assert!(LeastSquares::new(vec![[1.0, 2.0]; 10]).is_none());
        assert!(LeastSquares::<2>::new(Vec::new()).is_none());
        assert!(LeastSquares::new(vec![[1.0, f64::NAN], [1.0, 2.0]]).is_none());
    }

    proptest! {
        #[test]
        fn inverse_times_matrix_is_identity(m in prop::array::uniform4(prop::array::uniform4(-10.0f64..10.0))) {
            if let Some(inv) = invert(m) {
                for i in 0..4 {
                    for j in 0..4 {
                        let p: f64 = (0..4).map(|k| m[i][k] * inv[k][j]).sum();
                        let scale = m.iter().flatten().chain(inv.iter().flatten()).fold(1.0f64, |a, x| a.max(x.abs()));
                        prop_assert!((p - f64::from(u8::from(i == j))).abs() < 1e-9 * scale * scale);
                    }
                }
            }
        }
    }
}
