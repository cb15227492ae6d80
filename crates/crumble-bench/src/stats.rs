//! Percentiles of step times.

/// Summary of a list of per-step times, milliseconds.
#[derive(Clone, Copy, Debug, Default)]
pub struct Summary {
    pub median: f64,
    pub p10: f64,
    pub p90: f64,
    pub mean: f64,
}

/// The `q`-quantile (0..=1) of sorted data, interpolated linearly.
fn quantile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return f64::NAN;
    }
    let x = q * (sorted.len() - 1) as f64;
    let (i, f) = (x.floor() as usize, x.fract());
    let next = sorted[(i + 1).min(sorted.len() - 1)];
    sorted[i] + (next - sorted[i]) * f
}

pub fn summarize(times: &[f64]) -> Summary {
    let mut s = times.to_vec();
    s.sort_by(f64::total_cmp);
    let mean = if s.is_empty() { f64::NAN } else { s.iter().sum::<f64>() / s.len() as f64 };
    Summary { median: quantile(&s, 0.5), p10: quantile(&s, 0.1), p90: quantile(&s, 0.9), mean }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quantiles_of_a_known_list() {
        let s = summarize(&[5.0, 1.0, 3.0, 2.0, 4.0]);
        assert_eq!(s.median, 3.0);
        assert!((s.p10 - 1.4).abs() < 1e-12);
        assert!((s.p90 - 4.6).abs() < 1e-12);
        assert_eq!(s.mean, 3.0);
        assert!(summarize(&[]).median.is_nan());
    }
}
