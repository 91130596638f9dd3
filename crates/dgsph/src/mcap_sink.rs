//! MCAP output for Foxglove: particle frames as `foxglove.PointCloud` on `/particles`, the
//! records as JSON on `/metrics` (one key per record column), the scene as file metadata.
//! `log_time` is simulated time in ns.
//!
//! Open a file in Foxglove (app or web): *Open local file*, add a 3D panel, show `/particles`
//! (frame `world`) and colour by `pressure`, `det_f`, `free_surface` or `wall` (1 for the
//! wall particles, which a filter can hide); plot `/metrics` fields (`t`,
//! `rel_change_moments`, `p_centre`, ...) in a Plot panel.
//!
//! **Nothing is lost on a kill.** Every record ends the current chunk and flushes the file
//! (`McapWriterHandle::flush`), so a run killed with `kill -9` leaves a file whose complete
//! chunks a streaming reader (`mcap::MessageStream`, or `mcap recover` of the MCAP CLI, which
//! also rebuilds the index) reads up to the last record written; only the summary section at
//! the end, written when the run finishes, is missing.

use anyhow::Context as _;
use foxglove::messages::{
    PackedElementField, PointCloud, Pose, Quaternion, Timestamp, Vector3,
    packed_element_field::NumericType,
};
use foxglove::{Channel, McapCompression, McapWriteOptions, McapWriterHandle, RawChannel};
use sph_integrators::Frame;
use std::collections::BTreeMap;
use std::io::BufWriter;
use std::path::Path;
use std::sync::Arc;

/// Fields of every point, all `f32`, in this order (`det_f` is 1 without the `det_f`
/// diagnostic).
pub const FIELDS: [&str; 11] = [
    "x",
    "y",
    "z",
    "vx",
    "vy",
    "vz",
    "pressure",
    "density",
    "free_surface",
    "det_f",
    "wall",
];

/// An open MCAP file receiving frames.
pub struct McapSink {
    /// The context owns the sink registrations; it must live as long as the channels.
    _ctx: Arc<foxglove::Context>,
    writer: Option<McapWriterHandle<BufWriter<std::fs::File>>>,
    /// The file (named in errors).
    path: std::path::PathBuf,
    particles: Channel<PointCloud>,
    metrics: Arc<RawChannel>,
}

impl McapSink {
    /// Creates (or truncates) `path` with the given file metadata.
    pub fn create(path: &Path, metadata: BTreeMap<String, String>) -> anyhow::Result<Self> {
        let ctx = foxglove::Context::new();
        // Truncate an existing file (re-runs overwrite, like the CSVs); foxglove's
        // `create_new_buffered_file` refuses to, which broke a second `cargo xtask validate`.
        let file =
            std::fs::File::create(path).with_context(|| format!("creating {}", path.display()))?;
        let writer = ctx
            .mcap_writer_with_options(
                McapWriteOptions::new().compression(Some(McapCompression::Lz4)),
            )
            .create(BufWriter::new(file))
            .with_context(|| format!("starting MCAP in {}", path.display()))?;
        writer.write_metadata("scene", metadata)?;
        let particles = ctx.channel_builder("/particles").build::<PointCloud>();
        let metrics = ctx
            .channel_builder("/metrics")
            .message_encoding("json")
            .build_raw()
            .context("creating the /metrics channel")?;
        Ok(Self {
            _ctx: ctx,
            writer: Some(writer),
            path: path.to_path_buf(),
            particles,
            metrics,
        })
    }

    /// Logs the metrics (a flat JSON object) and, when `with_frame`, the particle frame; then
    /// ends the chunk and flushes, so a killed run keeps everything logged so far.
    pub fn record(
        &mut self,
        frame: &dyn Frame,
        metrics: &serde_json::Value,
        with_frame: bool,
    ) -> anyhow::Result<()> {
        let t_ns = (frame.time() * 1e9).round().max(0.0) as u64;
        if with_frame {
            self.particles
                .log_with_time(&point_cloud(frame, t_ns), t_ns);
        }
        let bytes = serde_json::to_vec(metrics)?;
        self.metrics
            .log_with_meta(&bytes, foxglove::PartialMetadata::with_log_time(t_ns));
        if let Some(w) = &self.writer {
            w.flush()
                .with_context(|| format!("writing {}", self.path.display()))?;
        }
        Ok(())
    }

    /// Finishes the file (summary and index). Also called on drop, so a failed run still leaves a
    /// readable file.
    pub fn finish(&mut self) -> anyhow::Result<()> {
        if let Some(w) = self.writer.take() {
            w.close()
                .with_context(|| format!("finishing {}", self.path.display()))?;
        }
        Ok(())
    }
}

impl Drop for McapSink {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

pub(crate) fn point_cloud(frame: &dyn Frame, t_ns: u64) -> PointCloud {
    let mut data = Vec::with_capacity(frame.len() * FIELDS.len() * 4);
    for i in 0..frame.len() {
        let (x, u) = (frame.position(i), frame.velocity(i));
        let values = [
            x[0],
            x[1],
            x[2],
            u[0],
            u[1],
            u[2],
            frame.pressure(i),
            frame.density(i),
            f64::from(u8::from(frame.free_surface(i))),
            frame.det_f(i),
            f64::from(u8::from(frame.wall(i))),
        ];
        for v in values {
            data.extend_from_slice(&(v as f32).to_le_bytes());
        }
    }
    PointCloud {
        timestamp: Some(Timestamp::new(
            (t_ns / 1_000_000_000) as u32,
            (t_ns % 1_000_000_000) as u32,
        )),
        frame_id: "world".to_string(),
        pose: Some(Pose {
            position: Some(Vector3 {
                x: 0.0,
                y: 0.0,
                z: 0.0,
            }),
            orientation: Some(Quaternion {
                x: 0.0,
                y: 0.0,
                z: 0.0,
                w: 1.0,
            }),
        }),
        point_stride: (FIELDS.len() * 4) as u32,
        fields: FIELDS
            .iter()
            .enumerate()
            .map(|(k, name)| PackedElementField {
                name: name.to_string(),
                offset: (k * 4) as u32,
                r#type: NumericType::Float32 as i32,
            })
            .collect(),
        data: data.into(),
    }
}
