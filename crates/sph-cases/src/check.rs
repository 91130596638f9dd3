use serde::Serialize;

/// One pass/fail comparison of a computed value with a reference value.
#[derive(Clone, Debug, Serialize, PartialEq)]
pub struct Check {
    /// Case the check belongs to, e.g. `"kernels"` or `"elliptical_drop"`.
    pub case: String,
    /// What is compared, e.g. `"quintic 3d ∫W dV"`.
    pub name: String,
    /// Computed value.
    pub value: f64,
    /// Reference (exact or published) value.
    pub reference: f64,
    /// Allowed absolute deviation `|value − reference|`.
    pub tolerance: f64,
    /// Where the reference comes from.
    pub source: String,
}

impl Check {
    /// A check of `value` against `reference` within `tolerance` (absolute).
    pub fn new(
        case: impl Into<String>,
        name: impl Into<String>,
        value: f64,
        reference: f64,
        tolerance: f64,
        source: impl Into<String>,
    ) -> Self {
        Self {
            case: case.into(),
            name: name.into(),
            value,
            reference,
            tolerance,
            source: source.into(),
        }
    }

    /// `|value − reference|`.
    pub fn deviation(&self) -> f64 {
        (self.value - self.reference).abs()
    }

    /// True if the deviation is within tolerance (and the value is finite).
    pub fn passed(&self) -> bool {
        self.value.is_finite() && self.deviation() <= self.tolerance
    }
}
