//! MCAP output for Foxglove: particle frames as `foxglove.PointCloud` on `/particles`, per-step
//! metrics as JSON on `/metrics`, the scene as file metadata. `log_time` is simulated time in ns.
//!
//! Open a file in Foxglove (app or web): *Open local file*, add a 3D panel, show `/particles`
//! (frame `world`) and colour by `pressure`, `det_f`, `free_surface` or `wall` (1 for the
//! fixed wall particles of a cavity, which a filter can hide); plot `/metrics` fields
//! (`t`, `rel_change_moments`, `p_centre`, ...) in a Plot panel.

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

/// Fields of every point, all `f32`, in this order.
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
    particles: Channel<PointCloud>,
    metrics: Arc<RawChannel>,
    stride: usize,
    calls: usize,
}

impl McapSink {
    /// Creates `path`, writing every `stride`-th frame (the first and the metrics always).
    pub fn create(
        path: &Path,
        stride: usize,
        metadata: BTreeMap<String, String>,
    ) -> anyhow::Result<Self> {
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
            particles,
            metrics,
            stride: stride.max(1),
            calls: 0,
        })
    }

    /// Logs the metrics (a flat JSON object) and, every `stride` calls, the particle frame.
    pub fn frame(&mut self, frame: &dyn Frame, metrics: &serde_json::Value) {
        let t_ns = (frame.time() * 1e9).round().max(0.0) as u64;
        if self.calls.is_multiple_of(self.stride) {
            self.particles
                .log_with_time(&point_cloud(frame, t_ns), t_ns);
        }
        self.calls += 1;
        let bytes = serde_json::to_vec(metrics).unwrap_or_default();
        self.metrics
            .log_with_meta(&bytes, foxglove::PartialMetadata::with_log_time(t_ns));
    }

    /// Finishes the file (summary and index). Also called on drop, so a failed run still leaves a
    /// readable file.
    pub fn finish(&mut self) -> anyhow::Result<()> {
        if let Some(w) = self.writer.take() {
            w.close().context("finishing the MCAP file")?;
        }
        Ok(())
    }
}

impl Drop for McapSink {
    fn drop(&mut self) {
        let _ = self.finish();
    }
}

fn point_cloud(frame: &dyn Frame, t_ns: u64) -> PointCloud {
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

#[cfg(test)]
mod tests {
    use super::*;
    use sph_cases::{CaseKind, Scene};
    use sph_core::D2;
    use sph_integrators::SchemeKind;

    #[test]
    fn written_file_reads_back_with_schemas_channels_and_counts() {
        let dir = std::env::temp_dir().join(format!("dgsph-mcap-test-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("drop.mcap");
        let scene = Scene {
            schemes: vec![SchemeKind::Dg],
            ..Scene::paper_drop(CaseKind::EllipticalDrop, 0.1, 2e-4, 6e-4)
        };
        let mut meta = BTreeMap::new();
        meta.insert("case".to_string(), "elliptical_drop".to_string());
        let mut sink = McapSink::create(&path, 2, meta).unwrap();
        let mut n_particles = 0;
        let records = sph_cases::drop::run::<D2>(
            &scene,
            SchemeKind::Dg,
            sph_cases::reference::References::embedded(),
            &mut |r, f| {
                n_particles = f.len();
                sink.frame(f, &serde_json::json!({ "t": r.t, "p_centre": r.p_centre }));
                Ok(())
            },
        )
        .unwrap();
        sink.finish().unwrap();
        assert_eq!(records.len(), 4); // t = 0 and 3 steps

        let bytes = std::fs::read(&path).unwrap();
        let summary = mcap::Summary::read(&bytes)
            .unwrap()
            .expect("summary section");
        let topics: BTreeMap<String, u16> = summary
            .channels
            .values()
            .map(|c| (c.topic.clone(), c.id))
            .collect();
        let particles = summary
            .channels
            .values()
            .find(|c| c.topic == "/particles")
            .unwrap();
        assert_eq!(
            particles.schema.as_ref().unwrap().name,
            "foxglove.PointCloud"
        );
        assert_eq!(particles.message_encoding, "protobuf");
        assert_eq!(
            summary
                .channels
                .values()
                .find(|c| c.topic == "/metrics")
                .unwrap()
                .message_encoding,
            "json"
        );
        let stats = summary.stats.as_ref().unwrap();
        let counts = &stats.channel_message_counts;
        // Stride 2 over 4 records: frames at calls 0 and 2; metrics every call.
        assert_eq!(counts[&topics["/particles"]], 2);
        assert_eq!(counts[&topics["/metrics"]], 4);
        // Messages decode: the last metrics message is the last record, in simulated ns.
        let msgs: Vec<_> = mcap::MessageStream::new(&bytes)
            .unwrap()
            .map(|m| m.unwrap())
            .collect();
        let last = msgs
            .iter()
            .rfind(|m| m.channel.topic == "/metrics")
            .unwrap();
        let json: serde_json::Value = serde_json::from_slice(&last.data).unwrap();
        assert!((json["t"].as_f64().unwrap() - 6e-4).abs() < 1e-12);
        assert_eq!(last.log_time, 600_000);
        let frame = msgs
            .iter()
            .find(|m| m.channel.topic == "/particles")
            .unwrap();
        // The protobuf payload holds every point: 11 f32 fields per particle plus the header.
        assert!(frame.data.len() > n_particles * FIELDS.len() * 4);
        std::fs::remove_dir_all(&dir).ok();
    }

    /// The `wall` field marks exactly the cavity's wall particles (stored after the fluid), so a
    /// Foxglove user can colour or hide them; the other fields sit at their documented offsets.
    #[test]
    fn point_cloud_fields_mark_wall_particles() {
        let text = std::fs::read_to_string(
            std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../cases/cavity_re100.toml"),
        )
        .unwrap();
        let scene = Scene::parse("cavity_re100", &text).unwrap();
        let setup = sph_cases::cavity::setup::<D2>(&scene).unwrap();
        let first_wall = setup.walls.first;
        let sim =
            sph_integrators::Simulation::with_walls(setup.particles, setup.config, setup.walls)
                .unwrap();
        let cloud = point_cloud(&sim, 0);
        let names: Vec<&str> = cloud.fields.iter().map(|f| f.name.as_str()).collect();
        assert_eq!(names, FIELDS);
        let stride = cloud.point_stride as usize;
        assert_eq!(cloud.data.len(), sim.len() * stride);
        let field = |i: usize, name: &str| {
            let k = FIELDS.iter().position(|f| *f == name).unwrap();
            let at = i * stride + k * 4;
            f32::from_le_bytes(cloud.data[at..at + 4].try_into().unwrap())
        };
        let walls: Vec<usize> = (0..sim.len())
            .filter(|&i| field(i, "wall") == 1.0)
            .collect();
        assert_eq!(walls, (first_wall..sim.len()).collect::<Vec<_>>());
        assert!((0..first_wall).all(|i| field(i, "wall") == 0.0));
        // Positions are in place: particle 0 of the 20² lattice sits at (dx/2, dx/2).
        assert_eq!((field(0, "x"), field(0, "y")), (0.025, 0.025));
    }

    #[test]
    fn an_existing_file_is_overwritten() {
        // Regression: a second `cargo xtask validate` failed with "File exists".
        let dir = std::env::temp_dir().join(format!("dgsph-mcap-overwrite-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("run.mcap");
        for _ in 0..2 {
            let mut sink = McapSink::create(&path, 1, BTreeMap::new()).unwrap();
            sink.finish().unwrap();
        }
        let bytes = std::fs::read(&path).unwrap();
        assert!(mcap::Summary::read(&bytes).unwrap().is_some());
        std::fs::remove_dir_all(&dir).ok();
    }
}
