//! ParaView output: one VTK XML PolyData file (`.vtp`) per particle frame and a `.pvd`
//! collection indexing them by simulated time.
//!
//! Each `.vtp` holds the particles as points (`Float64` positions, `z = 0` in 2D) with one
//! vertex cell each (so ParaView draws them as points), and the point fields `velocity`
//! (3 components), `pressure`, `density`, `det_f` (1 without the `det_f` diagnostic; `Float64`)
//! and `free_surface`, `wall` (`UInt8` flags). Data is appended raw (`encoding="raw"`,
//! `header_type="UInt64"`, little-endian), the compact form every VTK reader takes. Open the
//! `.pvd` in ParaView to step through time.
//!
//! The files of a run live in `<out>/<run>_vtk/` (`<run>_<step>.vtp`) with the index
//! `<out>/<run>.pvd`, rewritten after every frame, so a killed run's index lists every frame
//! written; a resumed run keeps the frames up to its checkpoint and continues the index.

use anyhow::Context;
use sph_integrators::Frame;
use std::io::Write;
use std::path::{Path, PathBuf};

/// The scalar and vector fields of every point, in file order.
pub const FIELDS: [&str; 6] = [
    "velocity",
    "pressure",
    "density",
    "det_f",
    "free_surface",
    "wall",
];

/// Writes one frame as VTK XML PolyData to `path`.
pub fn write_vtp(path: &Path, frame: &dyn Frame) -> anyhow::Result<()> {
    let n = frame.len();
    let mut arrays: Vec<(&str, &str, usize, Vec<u8>)> = Vec::new();
    let f64s = |f: &dyn Fn(usize) -> Vec<f64>| -> Vec<u8> {
        (0..n).flat_map(f).flat_map(|v| v.to_le_bytes()).collect()
    };
    arrays.push((
        "velocity",
        "Float64",
        3,
        f64s(&|i| frame.velocity(i).to_vec()),
    ));
    arrays.push(("pressure", "Float64", 1, f64s(&|i| vec![frame.pressure(i)])));
    arrays.push(("density", "Float64", 1, f64s(&|i| vec![frame.density(i)])));
    arrays.push(("det_f", "Float64", 1, f64s(&|i| vec![frame.det_f(i)])));
    arrays.push((
        "free_surface",
        "UInt8",
        1,
        (0..n).map(|i| u8::from(frame.free_surface(i))).collect(),
    ));
    arrays.push((
        "wall",
        "UInt8",
        1,
        (0..n).map(|i| u8::from(frame.wall(i))).collect(),
    ));
    let points = f64s(&|i| frame.position(i).to_vec());
    let connectivity: Vec<u8> = (0..n as i64).flat_map(|i| i.to_le_bytes()).collect();
    let offsets: Vec<u8> = (1..=n as i64).flat_map(|i| i.to_le_bytes()).collect();

    let mut xml = String::new();
    let mut blob: Vec<u8> = Vec::new();
    let add = |bytes: &[u8], blob: &mut Vec<u8>| -> usize {
        let at = blob.len();
        blob.extend_from_slice(&(bytes.len() as u64).to_le_bytes());
        blob.extend_from_slice(bytes);
        at
    };
    xml.push_str(
        "<?xml version=\"1.0\"?>\n<VTKFile type=\"PolyData\" version=\"1.0\" \
         byte_order=\"LittleEndian\" header_type=\"UInt64\">\n  <PolyData>\n",
    );
    xml.push_str(&format!(
        "    <Piece NumberOfPoints=\"{n}\" NumberOfVerts=\"{n}\" NumberOfLines=\"0\" \
         NumberOfStrips=\"0\" NumberOfPolys=\"0\">\n      <PointData Scalars=\"pressure\" \
         Vectors=\"velocity\">\n"
    ));
    for (name, ty, comps, bytes) in &arrays {
        let at = add(bytes, &mut blob);
        xml.push_str(&format!(
            "        <DataArray type=\"{ty}\" Name=\"{name}\" NumberOfComponents=\"{comps}\" \
             format=\"appended\" offset=\"{at}\"/>\n"
        ));
    }
    xml.push_str("      </PointData>\n      <Points>\n");
    let at = add(&points, &mut blob);
    xml.push_str(&format!(
        "        <DataArray type=\"Float64\" Name=\"Points\" NumberOfComponents=\"3\" \
         format=\"appended\" offset=\"{at}\"/>\n      </Points>\n      <Verts>\n"
    ));
    let at_c = add(&connectivity, &mut blob);
    let at_o = add(&offsets, &mut blob);
    xml.push_str(&format!(
        "        <DataArray type=\"Int64\" Name=\"connectivity\" format=\"appended\" \
         offset=\"{at_c}\"/>\n        <DataArray type=\"Int64\" Name=\"offsets\" \
         format=\"appended\" offset=\"{at_o}\"/>\n      </Verts>\n    </Piece>\n  </PolyData>\n  \
         <AppendedData encoding=\"raw\">\n   _"
    ));
    let tmp = path.with_extension("vtp.tmp");
    let mut f = std::io::BufWriter::new(
        std::fs::File::create(&tmp).with_context(|| format!("creating {}", tmp.display()))?,
    );
    f.write_all(xml.as_bytes())?;
    f.write_all(&blob)?;
    f.write_all(b"\n  </AppendedData>\n</VTKFile>\n")?;
    f.flush()?;
    drop(f);
    std::fs::rename(&tmp, path).with_context(|| format!("writing {}", path.display()))?;
    Ok(())
}

/// The frames of one run and their `.pvd` index.
pub struct VtkSeries {
    dir: PathBuf,
    pvd: PathBuf,
    run: String,
    /// (time, file name relative to the index's directory).
    frames: Vec<(f64, usize, String)>,
}

impl VtkSeries {
    /// The series of run `run` in `out`. With `resume_step`, the existing index's frames up to
    /// that step are kept (and later ones removed); otherwise the series starts empty.
    pub fn create(out: &Path, run: &str, resume_step: Option<usize>) -> anyhow::Result<Self> {
        let dir = out.join(format!("{run}_vtk"));
        std::fs::create_dir_all(&dir).with_context(|| format!("creating {}", dir.display()))?;
        let pvd = out.join(format!("{run}.pvd"));
        let mut frames = Vec::new();
        if let Some(step) = resume_step {
            if let Ok(text) = std::fs::read_to_string(&pvd) {
                frames = read_pvd(&text)
                    .into_iter()
                    .filter(|(_, s, _)| *s <= step)
                    .collect();
            }
        } else if let Ok(entries) = std::fs::read_dir(&dir) {
            // A fresh run replaces an earlier run's frames.
            for e in entries.flatten() {
                if e.path().extension().is_some_and(|x| x == "vtp") {
                    let _ = std::fs::remove_file(e.path());
                }
            }
        }
        Ok(Self {
            dir,
            pvd,
            run: run.to_string(),
            frames,
        })
    }

    /// Writes `frame` (step `step`) and rewrites the index.
    pub fn write(&mut self, frame: &dyn Frame, step: usize) -> anyhow::Result<()> {
        let file = format!("{}_{step:08}.vtp", self.run);
        write_vtp(&self.dir.join(&file), frame)?;
        let rel = format!(
            "{}/{file}",
            self.dir
                .file_name()
                .map_or(String::new(), |d| d.to_string_lossy().into_owned())
        );
        self.frames.retain(|(_, s, _)| *s != step);
        self.frames.push((frame.time(), step, rel));
        let mut text = String::from(
            "<?xml version=\"1.0\"?>\n<VTKFile type=\"Collection\" version=\"1.0\" \
             byte_order=\"LittleEndian\">\n  <Collection>\n",
        );
        for (t, s, f) in &self.frames {
            text.push_str(&format!(
                "    <DataSet timestep=\"{t:e}\" part=\"0\" file=\"{f}\"/><!-- step {s} -->\n"
            ));
        }
        text.push_str("  </Collection>\n</VTKFile>\n");
        let tmp = self.pvd.with_extension("pvd.tmp");
        std::fs::write(&tmp, text).with_context(|| format!("writing {}", tmp.display()))?;
        std::fs::rename(&tmp, &self.pvd)
            .with_context(|| format!("writing {}", self.pvd.display()))?;
        Ok(())
    }

    /// The index file.
    pub fn index(&self) -> &Path {
        &self.pvd
    }
}

/// `(time, step, file)` of the entries of a `.pvd` written by [`VtkSeries`].
pub fn read_pvd(text: &str) -> Vec<(f64, usize, String)> {
    let attr = |line: &str, key: &str| -> Option<String> {
        let at = line.find(&format!("{key}=\""))? + key.len() + 2;
        let end = line[at..].find('"')?;
        Some(line[at..at + end].to_string())
    };
    text.lines()
        .filter(|l| l.contains("<DataSet"))
        .filter_map(|l| {
            let t = attr(l, "timestep")?.parse().ok()?;
            let file = attr(l, "file")?;
            let step = l
                .split("<!-- step ")
                .nth(1)
                .and_then(|s| s.split_whitespace().next())
                .and_then(|s| s.parse().ok())?;
            Some((t, step, file))
        })
        .collect()
}

/// A `.vtp` file read back (the inverse of [`write_vtp`], for tests).
#[derive(Debug)]
pub struct VtpData {
    /// Number of points.
    pub points: usize,
    /// Point coordinates.
    pub positions: Vec<[f64; 3]>,
    /// `(name, components, values as f64)` of each point array.
    pub arrays: Vec<(String, usize, Vec<f64>)>,
}

/// Reads a `.vtp` written by [`write_vtp`].
pub fn read_vtp(bytes: &[u8]) -> anyhow::Result<VtpData> {
    let marker = b"<AppendedData encoding=\"raw\">\n   _";
    let at = bytes
        .windows(marker.len())
        .position(|w| w == marker)
        .context("no appended data")?;
    let header = std::str::from_utf8(&bytes[..at])?;
    let blob = &bytes[at + marker.len()..];
    let points: usize = header
        .split("NumberOfPoints=\"")
        .nth(1)
        .and_then(|s| s.split('"').next())
        .and_then(|s| s.parse().ok())
        .context("no point count")?;
    let attr = |line: &str, key: &str| -> Option<String> {
        let at = line.find(&format!(" {key}=\""))? + key.len() + 3;
        let end = line[at..].find('"')?;
        Some(line[at..at + end].to_string())
    };
    let mut arrays = Vec::new();
    let mut positions = Vec::new();
    for line in header.lines().filter(|l| l.contains("<DataArray")) {
        let name = attr(line, "Name").context("array name")?;
        let ty = attr(line, "type").context("array type")?;
        let comps: usize = attr(line, "NumberOfComponents").map_or(Ok(1), |c| c.parse())?;
        let offset: usize = attr(line, "offset").context("offset")?.parse()?;
        let len = u64::from_le_bytes(blob[offset..offset + 8].try_into()?) as usize;
        let data = &blob[offset + 8..offset + 8 + len];
        let values: Vec<f64> = match ty.as_str() {
            "Float64" => data
                .chunks_exact(8)
                .map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes")))
                .collect(),
            "Int64" => data
                .chunks_exact(8)
                .map(|c| i64::from_le_bytes(c.try_into().expect("8 bytes")) as f64)
                .collect(),
            "UInt8" => data.iter().map(|b| f64::from(*b)).collect(),
            other => anyhow::bail!("unexpected type {other}"),
        };
        if name == "Points" {
            positions = values.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
        } else if name != "connectivity" && name != "offsets" {
            arrays.push((name, comps, values));
        }
    }
    Ok(VtpData {
        points,
        positions,
        arrays,
    })
}
