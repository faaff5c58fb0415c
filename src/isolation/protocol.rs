//! The messages between the checker and its host process: one request,
//! then one reply, each a frame of a little-endian `u32` length and that
//! many bytes (a tag, then the fields). Numbers travel as their IEEE bits,
//! so a NaN payload or a signed zero arrives as sent; every length read is
//! bounded before anything is allocated for it.

use std::io::{self, Read, Write};

use serde::{Deserialize, Serialize};

/// The largest frame either side accepts: a batch of ten million samples
/// with its ticks.
pub const MAX_FRAME: usize = 256 << 20;

/// What a hosted candidate is and how it is loaded.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub enum CandidateSpec {
    /// An FMU (FMI 2.0 or 3.0 Co-Simulation), one `doStep` of
    /// `sample_time` per sample; `variables` renames ours to the FMU's.
    Fmu {
        path: String,
        role: Role,
        variables: Vec<(String, String)>,
        sample_time: f64,
    },
    /// A shared library with the step ABI (see [`crate::isolation`]).
    Library {
        path: String,
        role: Role,
        symbol_prefix: String,
        precision: Precision,
    },
}

impl CandidateSpec {
    /// The role, whichever the kind.
    pub fn role(&self) -> Role {
        match self {
            Self::Fmu { role, .. } | Self::Library { role, .. } => *role,
        }
    }

    /// The file, for messages.
    pub fn path(&self) -> &str {
        match self {
            Self::Fmu { path, .. } | Self::Library { path, .. } => path,
        }
    }
}

/// What a candidate computes, and so how many numbers go in and come out
/// per sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Role {
    /// `W` (or `H` alone): `u` in; `y` out.
    Model,
    /// `W⁻¹`: `y_d` in; `u`, saturated, fault out (flags as 0 or 1).
    Compensator,
    /// `H⁻¹`: `y` in; `u` out.
    InverseHysteresis,
    /// The closed loop's controller: reference and measurement in;
    /// correction and held out.
    Controller,
}

impl Role {
    /// Numbers per sample in.
    pub fn inputs(self) -> usize {
        match self {
            Self::Controller => 2,
            _ => 1,
        }
    }

    /// Numbers per sample out.
    pub fn outputs(self) -> usize {
        match self {
            Self::Model | Self::InverseHysteresis => 1,
            Self::Compensator => 3,
            Self::Controller => 2,
        }
    }
}

/// The floating-point type of a library's step.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Precision {
    F64,
    F32,
}

/// What the host learnt when it loaded the candidate.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Loaded {
    /// It can save and restore its state itself (an FMU's state functions).
    pub saves_state: bool,
    /// It takes the saturation limits per instance (an FMU's `u_min`,
    /// `u_max`; every library).
    pub takes_limits: bool,
    /// The FMU's default step size, if it states one.
    pub step_size: Option<f64>,
}

/// A request to the host.
#[derive(Debug, Clone, PartialEq)]
pub enum Request {
    /// Load the candidate (once, first).
    Load(CandidateSpec),
    /// Pin the host to one CPU.
    Pin(usize),
    /// A new instance: the model file it implements (a library's
    /// `create`; `None` for a fixed one) and its limits.
    New {
        model_file: Option<String>,
        limits: Option<(f64, f64)>,
    },
    /// Samples through an instance: `inputs` holds `Role::inputs` numbers
    /// per sample; `timed` asks for each step's ticks too.
    Run {
        instance: u32,
        inputs: Vec<f64>,
        timed: bool,
    },
    Save(u32),
    Restore {
        instance: u32,
        state: u32,
    },
    Free(u32),
}

/// The host's reply.
#[derive(Debug, Clone, PartialEq)]
pub enum Reply {
    Loaded(Loaded),
    Done,
    Created(u32),
    /// `Role::outputs` numbers per sample (NaN after an error), the ticks
    /// of each step if asked, and the first error of the batch.
    Ran {
        outputs: Vec<f64>,
        ticks: Vec<u64>,
        error: Option<String>,
    },
    Saved(Option<u32>),
    Restored(bool),
    /// The request could not be carried out (the candidate refused it).
    Refused(String),
}

/// A frame being written.
struct Out(Vec<u8>);

impl Out {
    fn u8(&mut self, v: u8) {
        self.0.push(v);
    }
    fn u32(&mut self, v: u32) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn u64(&mut self, v: u64) {
        self.0.extend_from_slice(&v.to_le_bytes());
    }
    fn f64(&mut self, v: f64) {
        self.u64(v.to_bits());
    }
    fn len(&mut self, n: usize) {
        // frames are bounded far below 4 G elements
        self.u32(u32::try_from(n).unwrap_or(u32::MAX));
    }
    fn f64s(&mut self, v: &[f64]) {
        self.len(v.len());
        for &x in v {
            self.f64(x);
        }
    }
    fn u64s(&mut self, v: &[u64]) {
        self.len(v.len());
        for &x in v {
            self.u64(x);
        }
    }
    fn bytes(&mut self, v: &[u8]) {
        self.len(v.len());
        self.0.extend_from_slice(v);
    }
    fn text(&mut self, v: &str) {
        self.bytes(v.as_bytes());
    }
    fn optional_text(&mut self, v: Option<&str>) {
        match v {
            Some(t) => {
                self.u8(1);
                self.text(t);
            }
            None => self.u8(0),
        }
    }
}

/// A frame being read: every read is checked against what is left.
struct In<'a>(&'a [u8]);

fn bad(what: &str) -> io::Error {
    io::Error::new(io::ErrorKind::InvalidData, format!("a malformed {what}"))
}

impl In<'_> {
    fn take(&mut self, n: usize) -> io::Result<&[u8]> {
        if n > self.0.len() {
            return Err(bad("frame (cut short)"));
        }
        let (head, rest) = self.0.split_at(n);
        self.0 = rest;
        Ok(head)
    }
    fn u8(&mut self) -> io::Result<u8> {
        Ok(self.take(1)?[0])
    }
    fn u32(&mut self) -> io::Result<u32> {
        let b = self.take(4)?;
        Ok(u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    }
    fn u64(&mut self) -> io::Result<u64> {
        let mut a = [0u8; 8];
        a.copy_from_slice(self.take(8)?);
        Ok(u64::from_le_bytes(a))
    }
    fn f64(&mut self) -> io::Result<f64> {
        Ok(f64::from_bits(self.u64()?))
    }
    /// A count of items of `size` bytes, checked against what is left.
    fn len(&mut self, size: usize) -> io::Result<usize> {
        let n = self.u32()? as usize;
        if n.saturating_mul(size) > self.0.len() {
            return Err(bad("frame (a count beyond its end)"));
        }
        Ok(n)
    }
    fn f64s(&mut self) -> io::Result<Vec<f64>> {
        let n = self.len(8)?;
        (0..n).map(|_| self.f64()).collect()
    }
    fn u64s(&mut self) -> io::Result<Vec<u64>> {
        let n = self.len(8)?;
        (0..n).map(|_| self.u64()).collect()
    }
    fn text(&mut self) -> io::Result<String> {
        let n = self.len(1)?;
        String::from_utf8(self.take(n)?.to_vec()).map_err(|_| bad("text"))
    }
    fn optional_text(&mut self) -> io::Result<Option<String>> {
        Ok(match self.u8()? {
            0 => None,
            _ => Some(self.text()?),
        })
    }
    fn json<T: for<'de> Deserialize<'de>>(&mut self) -> io::Result<T> {
        let t = self.text()?;
        serde_json::from_str(&t).map_err(|e| bad(&format!("description ({e})")))
    }
    fn end(self) -> io::Result<()> {
        if self.0.is_empty() {
            Ok(())
        } else {
            Err(bad("frame (bytes after its end)"))
        }
    }
}

fn json<T: Serialize>(out: &mut Out, v: &T) {
    // plain data: serialising cannot fail
    out.text(&serde_json::to_string(v).unwrap_or_default());
}

impl Request {
    fn encode(&self) -> Vec<u8> {
        let mut o = Out(Vec::new());
        match self {
            Self::Load(spec) => {
                o.u8(0);
                json(&mut o, spec);
            }
            Self::Pin(cpu) => {
                o.u8(1);
                o.u64(*cpu as u64);
            }
            Self::New { model_file, limits } => {
                o.u8(2);
                o.optional_text(model_file.as_deref());
                match limits {
                    Some((lo, hi)) => {
                        o.u8(1);
                        o.f64(*lo);
                        o.f64(*hi);
                    }
                    None => o.u8(0),
                }
            }
            Self::Run {
                instance,
                inputs,
                timed,
            } => {
                o.u8(3);
                o.u32(*instance);
                o.u8(u8::from(*timed));
                o.f64s(inputs);
            }
            Self::Save(i) => {
                o.u8(4);
                o.u32(*i);
            }
            Self::Restore { instance, state } => {
                o.u8(5);
                o.u32(*instance);
                o.u32(*state);
            }
            Self::Free(i) => {
                o.u8(6);
                o.u32(*i);
            }
        }
        o.0
    }

    fn decode(bytes: &[u8]) -> io::Result<Self> {
        let mut i = In(bytes);
        let r = match i.u8()? {
            0 => Self::Load(i.json()?),
            1 => Self::Pin(usize::try_from(i.u64()?).map_err(|_| bad("CPU"))?),
            2 => {
                let model_file = i.optional_text()?;
                let limits = match i.u8()? {
                    0 => None,
                    _ => Some((i.f64()?, i.f64()?)),
                };
                Self::New { model_file, limits }
            }
            3 => {
                let instance = i.u32()?;
                let timed = i.u8()? != 0;
                Self::Run {
                    instance,
                    timed,
                    inputs: i.f64s()?,
                }
            }
            4 => Self::Save(i.u32()?),
            5 => Self::Restore {
                instance: i.u32()?,
                state: i.u32()?,
            },
            6 => Self::Free(i.u32()?),
            _ => return Err(bad("request")),
        };
        i.end()?;
        Ok(r)
    }
}

impl Reply {
    fn encode(&self) -> Vec<u8> {
        let mut o = Out(Vec::new());
        match self {
            Self::Loaded(l) => {
                o.u8(0);
                json(&mut o, l);
            }
            Self::Done => o.u8(1),
            Self::Created(i) => {
                o.u8(2);
                o.u32(*i);
            }
            Self::Ran {
                outputs,
                ticks,
                error,
            } => {
                o.u8(3);
                o.f64s(outputs);
                o.u64s(ticks);
                o.optional_text(error.as_deref());
            }
            Self::Saved(s) => {
                o.u8(4);
                match s {
                    Some(k) => {
                        o.u8(1);
                        o.u32(*k);
                    }
                    None => o.u8(0),
                }
            }
            Self::Restored(ok) => {
                o.u8(5);
                o.u8(u8::from(*ok));
            }
            Self::Refused(why) => {
                o.u8(6);
                o.text(why);
            }
        }
        o.0
    }

    fn decode(bytes: &[u8]) -> io::Result<Self> {
        let mut i = In(bytes);
        let r = match i.u8()? {
            0 => Self::Loaded(i.json()?),
            1 => Self::Done,
            2 => Self::Created(i.u32()?),
            3 => Self::Ran {
                outputs: i.f64s()?,
                ticks: i.u64s()?,
                error: i.optional_text()?,
            },
            4 => Self::Saved(match i.u8()? {
                0 => None,
                _ => Some(i.u32()?),
            }),
            5 => Self::Restored(i.u8()? != 0),
            6 => Self::Refused(i.text()?),
            _ => return Err(bad("reply")),
        };
        i.end()?;
        Ok(r)
    }
}

fn write_frame(w: &mut impl Write, payload: &[u8]) -> io::Result<()> {
    if payload.len() > MAX_FRAME {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!(
                "a message of {} bytes, more than {MAX_FRAME}",
                payload.len()
            ),
        ));
    }
    w.write_all(&(payload.len() as u32).to_le_bytes())?;
    w.write_all(payload)?;
    w.flush()
}

/// One frame, or `None` at a clean end of the stream (before its length).
fn read_frame(r: &mut impl Read) -> io::Result<Option<Vec<u8>>> {
    let mut len = [0u8; 4];
    let mut got = 0;
    while got < 4 {
        match r.read(&mut len[got..]) {
            Ok(0) if got == 0 => return Ok(None),
            Ok(0) => return Err(io::ErrorKind::UnexpectedEof.into()),
            Ok(n) => got += n,
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) => return Err(e),
        }
    }
    let n = u32::from_le_bytes(len) as usize;
    if n > MAX_FRAME {
        return Err(bad("frame (longer than the largest)"));
    }
    // grown as the bytes arrive: a length alone allocates nothing
    let mut payload = Vec::new();
    r.take(n as u64).read_to_end(&mut payload)?;
    if payload.len() < n {
        return Err(io::ErrorKind::UnexpectedEof.into());
    }
    Ok(Some(payload))
}

/// Send a request.
pub fn send_request(w: &mut impl Write, r: &Request) -> io::Result<()> {
    write_frame(w, &r.encode())
}

/// The next request, `None` when the checker closed the stream.
pub fn read_request(r: &mut impl Read) -> io::Result<Option<Request>> {
    read_frame(r)?.map(|f| Request::decode(&f)).transpose()
}

/// Send a reply.
pub fn send_reply(w: &mut impl Write, r: &Reply) -> io::Result<()> {
    write_frame(w, &r.encode())
}

/// The reply, `None` when the host's stream ended before it.
pub fn read_reply(r: &mut impl Read) -> io::Result<Option<Reply>> {
    read_frame(r)?.map(|f| Reply::decode(&f)).transpose()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_message_decodes_to_itself_bit_for_bit() {
        let requests = [
            Request::Load(CandidateSpec::Library {
                path: "/x/lib.so".into(),
                role: Role::Compensator,
                symbol_prefix: "p".into(),
                precision: Precision::F32,
            }),
            Request::Pin(3),
            Request::New {
                model_file: Some("m.json".into()),
                limits: Some((-1.0, f64::INFINITY)),
            },
            Request::New {
                model_file: None,
                limits: None,
            },
            Request::Run {
                instance: 7,
                inputs: vec![1.5, -0.0, f64::NEG_INFINITY],
                timed: true,
            },
            Request::Save(1),
            Request::Restore {
                instance: 1,
                state: 2,
            },
            Request::Free(9),
        ];
        for r in &requests {
            let mut buf = Vec::new();
            send_request(&mut buf, r).unwrap();
            let back = read_request(&mut buf.as_slice()).unwrap().unwrap();
            assert_eq!(&back, r);
        }
        // a NaN with a payload keeps its bits
        let nan = f64::from_bits(0x7ff8_0000_dead_beef);
        let reply = Reply::Ran {
            outputs: vec![nan, -0.0],
            ticks: vec![0, u64::MAX],
            error: Some("doStep".into()),
        };
        let mut buf = Vec::new();
        send_reply(&mut buf, &reply).unwrap();
        match read_reply(&mut buf.as_slice()).unwrap().unwrap() {
            Reply::Ran { outputs, ticks, .. } => {
                assert_eq!(outputs[0].to_bits(), nan.to_bits());
                assert_eq!(outputs[1].to_bits(), (-0.0f64).to_bits());
                assert_eq!(ticks, vec![0, u64::MAX]);
            }
            r => panic!("{r:?}"),
        }
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(2000))]

        /// Any bytes, and any valid frame with bytes changed or cut, give a
        /// message or an error: never a panic.
        #[test]
        fn any_bytes_decode_or_fail_cleanly(
            bytes in proptest::collection::vec(proptest::prelude::any::<u8>(), 0..64),
            flips in proptest::collection::vec((0usize..64, proptest::prelude::any::<u8>()), 0..4),
            cut in 0usize..80,
        ) {
            let _ = read_request(&mut bytes.as_slice());
            let _ = read_reply(&mut bytes.as_slice());
            let mut valid = Vec::new();
            send_request(&mut valid, &Request::Run { instance: 1, inputs: vec![1.0, 2.0], timed: true }).unwrap();
            send_reply(&mut valid, &Reply::Ran { outputs: vec![0.5], ticks: vec![3], error: Some("e".into()) }).unwrap();
            for (at, b) in flips {
                if let Some(x) = valid.get_mut(at) {
                    *x = b;
                }
            }
            valid.truncate(cut);
            let mut r = valid.as_slice();
            let _ = read_request(&mut r);
            let _ = read_reply(&mut r);
        }
    }

    #[test]
    fn a_malformed_frame_is_an_error_not_an_allocation() {
        // a count of 2^32 - 1 f64s in a frame of a few bytes
        let mut frame = vec![3u8, 0, 0, 0, 0, 0];
        frame.extend_from_slice(&u32::MAX.to_le_bytes());
        let mut buf = (frame.len() as u32).to_le_bytes().to_vec();
        buf.extend_from_slice(&frame);
        assert!(read_request(&mut buf.as_slice()).is_err());
        // a length beyond the largest frame
        let buf = u32::MAX.to_le_bytes();
        assert!(read_reply(&mut buf.as_slice()).is_err());
        // cut short, and an unknown tag
        assert!(read_reply(&mut [5u8, 0, 0, 0, 3].as_slice()).is_err());
        assert!(read_reply(&mut [1u8, 0, 0, 0, 99].as_slice()).is_err());
        // a clean end
        assert!(read_reply(&mut [0u8; 0].as_slice()).unwrap().is_none());
    }
}
