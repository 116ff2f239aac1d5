//! Summary statistics of repeated timings.

/// Median, quartiles and extremes of a sample.
#[derive(Copy, Clone, Debug)]
pub struct Summary {
    /// Median.
    pub median: f64,
    /// Smallest value.
    pub min: f64,
    /// Largest value.
    pub max: f64,
    /// 25th percentile.
    pub p25: f64,
    /// 75th percentile.
    pub p75: f64,
}

impl Summary {
    /// Summarises `values` (at least one).
    pub fn of(values: &[f64]) -> Summary {
        let mut v = values.to_vec();
        v.sort_by(f64::total_cmp);
        let at = |q: f64| {
            if v.is_empty() {
                return f64::NAN;
            }
            let pos = q * (v.len() - 1) as f64;
            let (lo, hi) = (pos.floor() as usize, pos.ceil() as usize);
            v[lo] + (v[hi] - v[lo]) * (pos - lo as f64)
        };
        Summary { median: at(0.5), min: at(0.0), max: at(1.0), p25: at(0.25), p75: at(0.75) }
    }

    /// Half the interquartile range relative to the median, in percent.
    pub fn spread_percent(&self) -> f64 {
        50.0 * (self.p75 - self.p25) / self.median
    }

    /// As JSON.
    pub fn json(&self) -> serde_json::Value {
        serde_json::json!({ "median": self.median, "min": self.min, "max": self.max, "p25": self.p25, "p75": self.p75 })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn quartiles_interpolate() {
        let s = Summary::of(&[4.0, 1.0, 3.0, 2.0, 5.0]);
        assert_eq!((s.median, s.min, s.max, s.p25, s.p75), (3.0, 1.0, 5.0, 2.0, 4.0));
        assert!((s.spread_percent() - 100.0 / 3.0).abs() < 1e-9);
    }
}
