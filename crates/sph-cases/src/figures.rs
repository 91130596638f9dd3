//! What a report draws for a case: figure descriptions over the record columns and tables a
//! run writes. Data only; the `dgsph` binary renders them. A figure names columns, so a case's
//! figures change with its columns in one place ([`crate::registry::figures`]).

/// One curve family of a line figure.
#[derive(Clone, Debug, PartialEq)]
pub struct Series {
    /// The column plotted against the figure's x column.
    pub column: &'static str,
    /// How it is drawn.
    pub style: SeriesStyle,
    /// Legend text for reference series (per-scheme series are labelled `<scheme> <column>`).
    pub label: &'static str,
}

/// How a series is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SeriesStyle {
    /// One line per scheme.
    PerScheme,
    /// An exact solution, drawn once (from the first scheme's file) as a thin light line.
    Exact,
    /// Reference data, drawn once as markers.
    Reference,
}

impl Series {
    /// One line per scheme of `column`.
    pub fn per_scheme(column: &'static str) -> Self {
        Self {
            column,
            style: SeriesStyle::PerScheme,
            label: "",
        }
    }

    /// `column` holds an exact solution: one thin line.
    pub fn exact(column: &'static str) -> Self {
        Self {
            column,
            style: SeriesStyle::Exact,
            label: "",
        }
    }

    /// `column` holds reference data: markers, labelled `label`.
    pub fn reference(column: &'static str, label: &'static str) -> Self {
        Self {
            column,
            style: SeriesStyle::Reference,
            label,
        }
    }
}

/// A figure of a report.
#[derive(Clone, Debug, PartialEq)]
pub enum Figure {
    /// Lines of `series` against `x`, from the records (`table: None`) or from the table of
    /// that name written at the end of each scheme's run.
    Lines {
        /// File-name suffix (`<run>_<name>.svg`).
        name: &'static str,
        /// Title (the run name is prefixed).
        title: &'static str,
        /// Table name, or `None` for the records.
        table: Option<&'static str>,
        /// x column.
        x: &'static str,
        /// y-axis label.
        y_label: &'static str,
        /// The curves.
        series: Vec<Series>,
    },
    /// A heat map of `value` over the `x, y` (and, in 3D, `z`: the mid-depth slice) columns of
    /// the latest table whose name starts with `table_prefix`, per scheme.
    HeatMap {
        /// File-name suffix (`<run>_<scheme>_<name>.svg`).
        name: &'static str,
        /// Title.
        title: &'static str,
        /// Table-name prefix; the suffix is the time (`density_t10.000`).
        table_prefix: &'static str,
        /// The value column.
        value: &'static str,
    },
}

impl Figure {
    /// Lines over the records.
    pub fn lines(
        name: &'static str,
        title: &'static str,
        x: &'static str,
        y_label: &'static str,
        series: Vec<Series>,
    ) -> Self {
        Figure::Lines {
            name,
            title,
            table: None,
            x,
            y_label,
            series,
        }
    }

    /// Lines over a table.
    pub fn table_lines(
        name: &'static str,
        title: &'static str,
        table: &'static str,
        x: &'static str,
        y_label: &'static str,
        series: Vec<Series>,
    ) -> Self {
        Figure::Lines {
            name,
            title,
            table: Some(table),
            x,
            y_label,
            series,
        }
    }

    /// A heat map.
    pub fn heat_map(
        name: &'static str,
        title: &'static str,
        table_prefix: &'static str,
        value: &'static str,
    ) -> Self {
        Figure::HeatMap {
            name,
            title,
            table_prefix,
            value,
        }
    }
}
