//! The Q-table file: a JSON header (settings, counters, random stream, world state) and the
//! table's values, for checkpoints and exact resumption.

use crate::error::Result;
use serde_json::json;
use std::io::Read;
use std::io::Write;

use super::FORMAT;
use super::KnownState;
use super::MAGIC;
use super::QConfig;
use super::QLearner;
use super::QTable;
use super::Ties;
use super::VERSION;
use crate::error::Error;
use crate::rng::EngineRng;
use serde_json::Value;
use std::fs::File;
use std::io::BufReader;
use std::path::Path;

impl<W: KnownState> QLearner<W> {
    /// The header of the run's file: every setting, the counters, the random stream's state and
    /// the world's current state.
    pub fn header(&self) -> Value {
        let mut state = Vec::new();
        self.world.describe(&self.state, &mut state);
        json!({
            "format": FORMAT,
            "version": VERSION,
            "world": self.world.to_json(),
            "n_states": self.table.n_states,
            "n_actions": self.table.n_actions,
            "value_type": "f32",
            "byte_order": "little-endian",
            "layout": "row-major [state][action]; target tracking: state = (y * P + B) * P + C, P = 4 * width * height, B and C = (j * width + i) * 4 + heading",
            "gamma": self.config.gamma,
            "alpha": self.config.alpha,
            "epsilon": "min(1, 1/ln t), t = 1, 2, ... the update count",
            "seed": self.config.seed,
            "ties": self.config.ties.as_str(),
            "updates": self.updates,
            "reward_total": self.reward_total,
            "seconds": self.seconds,
            "rng": serde_json::to_value(&self.rng).expect("the generator serialises"),
            "world_state": state,
            "observation": self.y,
            "engine_version": crate::VERSION,
        })
    }

    /// Writes the run (header and table) to `path`, through a temporary file renamed at the end,
    /// so that an interrupted save never leaves a broken file. Format: [`MAGIC`], the header's
    /// length (u64, little-endian), the header (JSON), zero padding to a multiple of 64 bytes,
    /// then the `n_states × n_actions` values (f32, little-endian, row-major).
    pub fn save(&self, path: impl AsRef<Path>) -> Result<()> {
        let header = serde_json::to_vec(&self.header()).expect("JSON values serialise");
        crate::files::write_atomic(path.as_ref(), |out| {
            out.write_all(MAGIC)?;
            out.write_all(&(header.len() as u64).to_le_bytes())?;
            out.write_all(&header)?;
            out.write_all(&vec![0u8; padding(header.len())])?;
            let mut bytes = Vec::with_capacity(1 << 22);
            for chunk in self.table.values().chunks(1 << 20) {
                bytes.clear();
                bytes.extend(chunk.iter().flat_map(|v| v.to_le_bytes()));
                out.write_all(&bytes)?;
            }
            Ok(())
        })
    }

    /// Reads a run saved by [`QLearner::save`] for `world` (which must be the file's world).
    pub fn load(path: impl AsRef<Path>, world: W) -> Result<Self> {
        let path = path.as_ref();
        let with_path = |message: String| Error::PolicyFormat { path: Some(path.to_path_buf()), message };
        let (header, data_offset, mut reader) = open_table(path)?;
        if header.get("world") != Some(&world.to_json()) {
            return Err(Error::Mismatch(format!(
                "the Q table was learnt in the world {}, not {}",
                header.get("world").unwrap_or(&Value::Null),
                world.to_json()
            )));
        }
        let number = |key: &str| {
            header
                .get(key)
                .and_then(Value::as_u64)
                .ok_or_else(|| with_path(format!("header key {key:?} is missing or not a count")))
        };
        let float = |key: &str| {
            header
                .get(key)
                .and_then(Value::as_f64)
                .ok_or_else(|| with_path(format!("header key {key:?} is missing or not a number")))
        };
        let (n_states, n_actions) = (number("n_states")? as usize, number("n_actions")? as usize);
        if n_states != world.n_states()? || n_actions != world.n_decisions() {
            return Err(with_path(format!(
                "{n_states} × {n_actions} values (the world has {} states × {} actions)",
                world.n_states()?,
                world.n_decisions()
            )));
        }
        if header.get("value_type").and_then(Value::as_str) != Some("f32") {
            return Err(with_path(format!("value_type {:?} (expected \"f32\")", header.get("value_type"))));
        }
        let ties = header.get("ties").and_then(Value::as_str).unwrap_or("missing");
        let ties = Ties::parse(ties).map_err(|e| with_path(e.to_string()))?;
        let config = QConfig { gamma: float("gamma")?, alpha: float("alpha")?, seed: number("seed")?, ties };
        config.validate().map_err(|e| with_path(e.to_string()))?;
        let rng: EngineRng = serde_json::from_value(header.get("rng").cloned().unwrap_or(Value::Null))
            .map_err(|e| with_path(format!("rng: {e}")))?;
        let values: Vec<i64> = serde_json::from_value(header.get("world_state").cloned().unwrap_or(Value::Null))
            .map_err(|e| with_path(format!("world_state: {e}")))?;
        let state = world.restore(&values).map_err(|e| with_path(e.to_string()))?;
        let y = number("observation")? as usize;
        if y >= world.n_observations() {
            return Err(with_path(format!("observation {y} (expected < {})", world.n_observations())));
        }
        let expected = data_offset + (n_states * n_actions * 4) as u64;
        let length = std::fs::metadata(path).map_err(|source| Error::Io { path: path.to_path_buf(), source })?.len();
        if length != expected {
            return Err(with_path(format!(
                "{length} bytes (expected {expected}: the header and {n_states} × {n_actions} f32 values)"
            )));
        }
        let mut table = QTable::zeros(n_states, n_actions)?;
        let mut bytes = vec![0u8; 1 << 22];
        for chunk in table.values_mut().chunks_mut(1 << 20) {
            let bytes = &mut bytes[..chunk.len() * 4];
            reader.read_exact(bytes).map_err(|source| Error::Io { path: path.to_path_buf(), source })?;
            for (v, b) in chunk.iter_mut().zip(bytes.chunks_exact(4)) {
                *v = f32::from_le_bytes([b[0], b[1], b[2], b[3]]);
            }
        }
        Ok(QLearner {
            world,
            config,
            table,
            state,
            y,
            updates: number("updates")?,
            rng,
            reward_total: float("reward_total")?,
            seconds: float("seconds")?,
        })
    }
}

/// Zero bytes after a header of `len` bytes so that the values start on a multiple of 64.
fn padding(len: usize) -> usize {
    (64 - (16 + len) % 64) % 64
}

/// Opens a Q-table file: its header, the offset of its values, and a reader positioned there.
fn open_table(path: &Path) -> Result<(Value, u64, BufReader<File>)> {
    let bad = |message: String| Error::PolicyFormat { path: Some(path.to_path_buf()), message };
    let mut reader = BufReader::with_capacity(8 << 20, crate::files::open_regular(path, "q table")?);
    let mut start = [0u8; 16];
    reader.read_exact(&mut start).map_err(|_| bad("not a cehmm Q table (shorter than its 16-byte prefix)".into()))?;
    if &start[..8] != MAGIC {
        return Err(bad(format!("not a cehmm Q table (the file does not start with {:?})", "CEQTABLE")));
    }
    let len = u64::from_le_bytes(start[8..16].try_into().expect("8 bytes"));
    if len > 1 << 24 {
        return Err(bad(format!("header of {len} bytes (expected at most 16 MiB)")));
    }
    let mut text = vec![0u8; len as usize + padding(len as usize)];
    reader.read_exact(&mut text).map_err(|_| bad("truncated header".into()))?;
    let header: Value =
        serde_json::from_slice(&text[..len as usize]).map_err(|e| bad(format!("header is not JSON: {e}")))?;
    if header.get("format").and_then(Value::as_str) != Some(FORMAT) {
        return Err(bad(format!("format {:?} (expected {FORMAT:?})", header.get("format"))));
    }
    if header.get("version").and_then(Value::as_u64) != Some(VERSION) {
        return Err(bad(format!("version {:?} (expected {VERSION})", header.get("version"))));
    }
    Ok((header, 16 + text.len() as u64, reader))
}

/// The header of a Q-table file (its world, settings and counters), without reading the table.
pub fn read_header(path: impl AsRef<Path>) -> Result<Value> {
    Ok(open_table(path.as_ref())?.0)
}
