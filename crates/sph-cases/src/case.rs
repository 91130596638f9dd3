//! The [`Case`] abstraction: what a case supplies to the one run loop ([`crate::run`]).
//!
//! A case builds the initial state ([`Case::setup`]), names the columns it adds to every record
//! ([`Case::columns`]) and fills them ([`Case::observe`]), may hand out tables (snapshots,
//! profiles) and named results at the end ([`Case::finish`]), and declares its built-in checks
//! ([`Case::checks`]). Everything else — stepping, sampling, the common columns (time, energy,
//! penetrations, solver statistics, per-pass timings), checkpoints, resume, blow-up handling and
//! the checks a scene declares in `[[check]]` — is the run loop's, once for every case. Cases
//! are registered by [`CaseKind`](crate::CaseKind) in [`crate::registry`].

use crate::{CaseError, Check};
use sph_core::{Dim, ParticleSet};
use sph_integrators::{
    Integrator, Scheme, SchemeKind, SimConfig, Simulation, StepError, StepReport, Walls,
};
use std::collections::BTreeMap;

/// A column of a run's records.
#[derive(Clone, Debug, PartialEq)]
pub struct Column {
    /// Name (`snake_case`), the CSV header and the MCAP metrics key.
    pub name: String,
    /// Unit, or `""` for dimensionless and counts.
    pub unit: &'static str,
    /// What it holds.
    pub about: &'static str,
}

impl Column {
    /// A column.
    pub fn new(name: impl Into<String>, unit: &'static str, about: &'static str) -> Self {
        Self {
            name: name.into(),
            unit,
            about,
        }
    }
}

/// A numeric table a case hands out (a density-error field, centreline profiles). The values
/// are stored row after row in one array: a field at every particle of a 10⁶-particle run is
/// then 8 bytes per value, not a separately allocated row each.
#[derive(Clone, Debug, PartialEq)]
pub struct Table {
    /// Name, part of the output file name (`density_t10.000`, `u_profile`).
    pub name: String,
    /// Column names.
    pub columns: Vec<String>,
    /// The values, row-major: row `r` is `values[r·c .. (r + 1)·c]` for `c` columns (NaN where
    /// a value does not exist).
    pub values: Vec<f64>,
}

impl Table {
    /// A table of `columns` whose rows are the items of `rows` (each as many values as there
    /// are columns).
    pub fn from_rows<const C: usize>(
        name: impl Into<String>,
        columns: [&str; C],
        rows: impl IntoIterator<Item = [f64; C]>,
    ) -> Self {
        Self {
            name: name.into(),
            columns: columns.map(String::from).to_vec(),
            values: rows.into_iter().flatten().collect(),
        }
    }

    /// The rows, each a slice of one value per column (none for a table without columns).
    pub fn rows(&self) -> std::slice::ChunksExact<'_, f64> {
        self.values.chunks_exact(self.columns.len().max(1))
    }
}

/// Named scalar results of a run (`reached_t`, `max_wall_penetrations`, `front_error_max`, ...):
/// what checks and reports read.
pub type Results = BTreeMap<String, f64>;

/// The initial state of a run.
pub struct Setup<D: Dim> {
    /// Fluid particles, then wall particles.
    pub particles: ParticleSet<D>,
    /// Numerical configuration.
    pub config: SimConfig,
    /// The walls, if any.
    pub walls: Option<Walls<D>>,
    /// Lattice sites of fluid blocks left out because they lie in wall material.
    pub carved: usize,
}

impl<D: Dim> Setup<D> {
    /// The simulation of this state.
    pub fn simulation(self) -> Result<Simulation<D>, CaseError> {
        match self.walls {
            Some(w) => Simulation::with_walls(self.particles, self.config, w)
                .map_err(|e| CaseError::Walls(e.to_string())),
            None => Ok(Simulation::new(self.particles, self.config)?),
        }
    }
}

/// What a case hands out at the end of a run.
#[derive(Default)]
pub struct Finish {
    /// Tables (written as `<run>_<table>.csv`).
    pub tables: Vec<Table>,
    /// Named results.
    pub results: Results,
}

/// What a case supplies to the run loop (see the module docs). One value per scheme run.
pub trait Case<D: Dim>: Send {
    /// The initial state.
    fn setup(&self) -> Result<Setup<D>, CaseError>;

    /// The columns this case adds to every record.
    fn columns(&self) -> Vec<Column>;

    /// Steps between records when the scene does not say (`steps`: the run's step count).
    /// Default: about 400 records per run.
    fn sample_every(&self, steps: usize) -> usize {
        (steps / 400).max(1)
    }

    /// Records between particle frames when the scene does not say. Default 10.
    fn frame_every(&self) -> usize {
        10
    }

    /// The velocity scale `U` of the `max_speed_ratio` result. Default `None`: the run loop
    /// takes the initial largest fluid speed, or `√(|g| H)` for fluid starting at rest under
    /// gravity (`H`: the fluid's initial height along `g`).
    fn velocity_scale(&self) -> Option<f64> {
        None
    }

    /// Called once with the initial state, before a resumed run restores its checkpoint.
    fn start(&mut self, _sim: &Simulation<D>) -> Result<(), CaseError> {
        Ok(())
    }

    /// Advances the simulation by one step. Default: the scheme's step. (The Section 3 case
    /// advects its particles with a prescribed field instead.)
    fn advance(
        &mut self,
        sim: &mut Simulation<D>,
        scheme: &mut Scheme,
        dt: f64,
    ) -> Result<StepReport, StepError> {
        scheme.step(sim, dt)
    }

    /// Appends this case's column values for the current state (`report`: the step just taken,
    /// `None` for the initial record; `short`: a final step shorter than `dt`).
    fn observe(
        &mut self,
        sim: &Simulation<D>,
        report: Option<&StepReport>,
        short: bool,
        out: &mut Vec<f64>,
    ) -> Result<(), CaseError>;

    /// Tables at a snapshot time of the scene (`[output] snapshots`). Default none.
    fn snapshot(&mut self, _sim: &Simulation<D>) -> Result<Vec<Table>, CaseError> {
        Ok(Vec::new())
    }

    /// Tables and results at the end of the run.
    fn finish(&mut self, _sim: &Simulation<D>) -> Result<Finish, CaseError> {
        Ok(Finish::default())
    }

    /// The case's built-in checks of one scheme's run, from the results (the loop's and the
    /// case's). `label` prefixes the check names.
    fn checks(&self, _scheme: SchemeKind, _label: &str, _results: &Results) -> Vec<Check> {
        Vec::new()
    }

    /// What this case's measurements have accumulated so far (maxima, histories, the values
    /// taken at the start), for a checkpoint: a resumed run restores it
    /// ([`Case::restore_state`]) so that its results cover the whole run. Default: nothing.
    fn save_state(&self) -> Vec<u8> {
        Vec::new()
    }

    /// Restores what [`Case::save_state`] wrote (after [`Case::start`]). Default: nothing.
    fn restore_state(&mut self, _bytes: &[u8]) -> Result<(), CaseError> {
        Ok(())
    }
}

/// A case's run state as named fields, encoded as one CBOR map (every `f64`, NaN included,
/// exactly): [`Case::save_state`] puts its fields, [`StateReader`] reads them back by name.
#[derive(Default)]
pub struct StateWriter(Vec<(ciborium::Value, ciborium::Value)>);

impl StateWriter {
    /// Adds field `name`.
    pub fn put<T: serde::Serialize + ?Sized>(&mut self, name: &str, value: &T) {
        let v = ciborium::Value::serialized(value).expect("in-memory CBOR encoding");
        self.0.push((ciborium::Value::Text(name.into()), v));
    }

    /// The encoded map.
    pub fn finish(self) -> Vec<u8> {
        let mut out = Vec::new();
        ciborium::into_writer(&ciborium::Value::Map(self.0), &mut out)
            .expect("writing CBOR to memory");
        out
    }
}

/// Reads the fields a [`StateWriter`] wrote; a missing or mistyped field is a
/// [`CaseError::Resume`] naming it.
pub struct StateReader(Vec<(ciborium::Value, ciborium::Value)>);

impl StateReader {
    /// Decodes `bytes` (a map written by [`StateWriter::finish`]).
    pub fn new(bytes: &[u8]) -> Result<Self, CaseError> {
        match ciborium::from_reader::<ciborium::Value, _>(bytes) {
            Ok(ciborium::Value::Map(m)) => Ok(Self(m)),
            Ok(_) => Err(CaseError::Resume(
                "the checkpoint's run state is not a map of fields".into(),
            )),
            Err(e) => Err(CaseError::Resume(format!(
                "the checkpoint's run state cannot be read: {e}"
            ))),
        }
    }

    /// Field `name`.
    pub fn get<T: serde::de::DeserializeOwned>(&self, name: &str) -> Result<T, CaseError> {
        let v = self
            .0
            .iter()
            .find(|(k, _)| k.as_text() == Some(name))
            .map(|(_, v)| v)
            .ok_or_else(|| {
                CaseError::Resume(format!("the checkpoint's run state has no `{name}`"))
            })?;
        v.deserialized()
            .map_err(|e| CaseError::Resume(format!("the checkpoint's run state: `{name}`: {e}")))
    }
}

/// `save_state` and `restore_state` of a [`Case`] whose run state is the listed fields of
/// `self` (each `Serialize + DeserializeOwned`), stored under their names.
macro_rules! state_fields {
    ($($field:ident),* $(,)?) => {
        fn save_state(&self) -> Vec<u8> {
            let mut w = $crate::case::StateWriter::default();
            $( w.put(stringify!($field), &self.$field); )*
            w.finish()
        }

        fn restore_state(&mut self, bytes: &[u8]) -> Result<(), $crate::CaseError> {
            let r = $crate::case::StateReader::new(bytes)?;
            $( self.$field = r.get(stringify!($field))?; )*
            Ok(())
        }
    };
}
pub(crate) use state_fields;

#[cfg(test)]
mod tests {
    use super::Table;

    /// A table built from rows gives the same rows back, in order, with NaN kept.
    #[test]
    fn table_rows_round_trip() {
        let rows = [[1.0, 2.0, 3.0], [4.0, f64::NAN, 6.0]];
        let t = Table::from_rows("t", ["a", "b", "c"], rows);
        assert_eq!(t.columns, ["a", "b", "c"]);
        assert_eq!(t.values.len(), 6);
        let back: Vec<&[f64]> = t.rows().collect();
        assert_eq!(back.len(), 2);
        assert_eq!(back[0], &[1.0, 2.0, 3.0]);
        assert_eq!(back[1][0], 4.0);
        assert!(back[1][1].is_nan());
        assert_eq!(back[1][2], 6.0);
    }
}
