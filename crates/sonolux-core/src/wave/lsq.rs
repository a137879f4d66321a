//! Small dense least-squares solvers for the wall fits ([`super::fit`]).

/// Non-negative least squares, min ‖A x − b‖ with x ≥ 0 (A is m×k, row-major), by the active
/// set method of Lawson and Hanson (1974, ch. 23).
pub(crate) fn nnls(a: &[f64], b: &[f64], m: usize, k: usize) -> Vec<f64> {
    let mut x = vec![0.0; k];
    let mut passive = vec![false; k];
    let gradient = |x: &[f64]| -> Vec<f64> {
        let r: Vec<f64> = (0..m).map(|i| b[i] - (0..k).map(|j| a[i * k + j] * x[j]).sum::<f64>()).collect();
        (0..k).map(|j| (0..m).map(|i| a[i * k + j] * r[i]).sum()).collect()
    };
    // Least squares restricted to the passive set, by the normal equations.
    let restricted = |passive: &[bool]| -> Vec<f64> {
        let idx: Vec<usize> = (0..k).filter(|&j| passive[j]).collect();
        let n = idx.len();
        let mut ata = vec![0.0; n * n];
        let mut atb = vec![0.0; n];
        for i in 0..m {
            for (p, &jp) in idx.iter().enumerate() {
                atb[p] += a[i * k + jp] * b[i];
                for (q, &jq) in idx.iter().enumerate() {
                    ata[p * n + q] += a[i * k + jp] * a[i * k + jq];
                }
            }
        }
        for p in 0..n {
            ata[p * n + p] *= 1.0 + 1e-12;
        }
        let mut z = vec![0.0; k];
        if solve_dense(&mut ata, &mut atb, n) {
            for (p, &j) in idx.iter().enumerate() {
                z[j] = atb[p];
            }
        }
        z
    };
    let scale = a.iter().map(|v| v.abs()).fold(0.0, f64::max) * b.iter().map(|v| v.abs()).fold(0.0, f64::max);
    let tol = 1e-12 * scale.max(1e-300) * m as f64;
    for _ in 0..3 * k {
        let w = gradient(&x);
        let Some(t) = (0..k).filter(|&j| !passive[j] && w[j] > tol).max_by(|&i, &j| w[i].total_cmp(&w[j])) else { break };
        passive[t] = true;
        loop {
            let z = restricted(&passive);
            if (0..k).all(|j| !passive[j] || z[j] > 0.0) {
                x = z;
                break;
            }
            let alpha = (0..k)
                .filter(|&j| passive[j] && z[j] <= 0.0)
                .map(|j| x[j] / (x[j] - z[j]))
                .fold(f64::INFINITY, f64::min);
            for j in 0..k {
                x[j] += alpha * (z[j] - x[j]);
                if passive[j] && x[j] <= 1e-15 {
                    passive[j] = false;
                    x[j] = 0.0;
                }
            }
            if !passive.iter().any(|&p| p) {
                break;
            }
        }
    }
    x
}

/// Solves the k×k system `a`·x = `b` in place (Gaussian elimination, partial pivoting); false
/// when singular.
pub(crate) fn solve_dense(a: &mut [f64], b: &mut [f64], k: usize) -> bool {
    for col in 0..k {
        let pivot = (col..k).max_by(|&i, &j| a[i * k + col].abs().total_cmp(&a[j * k + col].abs())).unwrap_or(col);
        if !(a[pivot * k + col].abs() > 1e-300) {
            return false;
        }
        if pivot != col {
            for c in 0..k {
                a.swap(pivot * k + c, col * k + c);
            }
            b.swap(pivot, col);
        }
        for row in col + 1..k {
            let f = a[row * k + col] / a[col * k + col];
            for c in col..k {
                a[row * k + c] -= f * a[col * k + c];
            }
            b[row] -= f * b[col];
        }
    }
    for row in (0..k).rev() {
        let s: f64 = (row + 1..k).map(|c| a[row * k + c] * b[c]).sum();
        b[row] = (b[row] - s) / a[row * k + row];
    }
    b.iter().all(|x| x.is_finite())
}
