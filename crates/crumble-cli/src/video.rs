//! Rendered outputs: an animated GIF, a directory of PNG frames, or an MP4
//! made by ffmpeg. Each is written whole or not at all: GIF and MP4 go to a
//! hidden temporary file renamed at the end; PNG frames go to a hidden
//! temporary directory renamed at the end when the directory is new, or
//! file by file (each atomically) into a directory that already exists.

use std::fs::{self, File};
use std::io::{self, BufWriter, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::thread::JoinHandle;

use crate::output::{temp_path, write_atomic, Temporary};

/// Most pixels in one rendered image: 2^25 (33.5 million; 8K UHD,
/// 7680 × 4320, fits). Drawing and encoding an image takes about 45 bytes
/// a pixel (0.9 GB measured for 4096 × 4096 on llvmpipe), so about 1.5 GB;
/// 16384 × 16384 would take 12 GB.
pub const MAX_FRAME_PIXELS: u64 = 1 << 25;

/// Most pixels one run renders, all frames together: 2^34 (17 billion),
/// about 25 minutes on a CPU rasteriser (llvmpipe draws and encodes about
/// 12 million pixels a second here); 4.6 minutes of 1080p at 30 fps.
pub const MAX_RENDERED_PIXELS: u64 = 1 << 34;

/// Name of frame `k` in a PNG sequence.
pub fn frame_name(k: usize) -> String {
    format!("frame_{k:05}.png")
}

/// Encodes one RGBA8 image as PNG (fast compression: frames are many).
pub fn encode_png(w: impl Write, rgba: &[u8], width: u32, height: u32) -> io::Result<()> {
    let mut enc = png::Encoder::new(w, width, height);
    enc.set_color(png::ColorType::Rgba);
    enc.set_depth(png::BitDepth::Eight);
    enc.set_compression(png::Compression::Fast);
    let mut writer = enc.write_header().map_err(io::Error::other)?;
    writer.write_image_data(rgba).map_err(io::Error::other)?;
    writer.finish().map_err(io::Error::other)
}

/// PNG frames `frame_00000.png`, `frame_00001.png`, ... in a directory
/// (numbered from another frame with [`PngFrames::numbered_from`]).
pub struct PngFrames {
    dir: PathBuf,
    /// A temporary sibling of `dir` the frames are written to, renamed to
    /// `dir` by [`PngFrames::finish`]; `None` when `dir` exists and they go
    /// straight into it.
    staged: Option<Temporary>,
    width: u32,
    height: u32,
    /// The number of the next frame.
    next: usize,
}

impl PngFrames {
    /// Frames of `width` × `height` into `dir`, which is created (by a
    /// rename at the end) if it does not exist; its parent must.
    pub fn create(dir: &Path, width: u32, height: u32) -> io::Result<Self> {
        let dir = dir.to_path_buf();
        let staged = if dir.is_dir() {
            None
        } else {
            let tmp = Temporary::new(temp_path(&dir));
            fs::create_dir(tmp.path())?;
            Some(tmp)
        };
        Ok(Self { dir, staged, width, height, next: 0 })
    }

    /// The same, its first frame numbered `first`: a resumed run's frames
    /// keep their numbers in the whole run.
    pub fn numbered_from(mut self, first: usize) -> Self {
        self.next = first;
        self
    }

    /// Writes the next frame.
    pub fn push(&mut self, rgba: &[u8]) -> io::Result<()> {
        if let Some(tmp) = &self.staged {
            let mut w = BufWriter::new(File::create(tmp.path().join(frame_name(self.next)))?);
            encode_png(&mut w, rgba, self.width, self.height)?;
            w.flush()?;
        } else {
            let path = self.dir.join(frame_name(self.next));
            write_atomic(&path, |w| encode_png(w, rgba, self.width, self.height))?;
        }
        self.next += 1;
        Ok(())
    }

    /// Puts the frames in place.
    pub fn finish(mut self) -> io::Result<()> {
        if let Some(tmp) = &mut self.staged {
            fs::rename(tmp.path(), &self.dir)?;
            tmp.keep();
        }
        Ok(())
    }
}

/// An animated GIF with one palette for all frames.
///
/// The palette (255 colours) is learnt from the first frame with NeuQuant;
/// every later frame stores only the rectangle that changed, with unchanged
/// pixels transparent (index 255), which keeps a mostly still scene small.
/// Frame delays are rounded so that their running total follows the frame
/// rate exactly.
pub struct GifWriter {
    path: PathBuf,
    tmp: Temporary,
    encoder: Option<gif::Encoder<BufWriter<File>>>,
    quantizer: Option<color_quant::NeuQuant>,
    width: u16,
    height: u16,
    fps: u32,
    previous: Vec<u8>,
    count: u64,
}

/// Palette index of "unchanged since the last frame".
const TRANSPARENT: u8 = 255;

impl GifWriter {
    /// A GIF of `width` × `height` (each at most 65535) at `fps` frames per
    /// second, written to `path` when finished.
    pub fn create(path: &Path, width: u32, height: u32, fps: u32) -> io::Result<Self> {
        let (Ok(w), Ok(h)) = (u16::try_from(width), u16::try_from(height)) else {
            return Err(io::Error::other("a GIF is at most 65535 pixels on a side"));
        };
        let tmp = Temporary::new(temp_path(path));
        File::create(tmp.path())?;
        Ok(Self {
            path: path.to_path_buf(),
            tmp,
            encoder: None,
            quantizer: None,
            width: w,
            height: h,
            fps,
            previous: Vec::new(),
            count: 0,
        })
    }

    /// Adds the next frame (RGBA8, `width * height * 4` bytes).
    pub fn push(&mut self, rgba: &[u8]) -> io::Result<()> {
        let (w, h) = (self.width as usize, self.height as usize);
        if rgba.len() != w * h * 4 {
            return Err(io::Error::other(format!("frame has {} bytes, expected {}", rgba.len(), w * h * 4)));
        }
        if self.quantizer.is_none() {
            let nq = color_quant::NeuQuant::new(10, 255, rgba);
            let mut palette = nq.color_map_rgb();
            palette.resize(256 * 3, 0);
            let file = BufWriter::new(File::create(self.tmp.path())?);
            let mut enc = gif::Encoder::new(file, self.width, self.height, &palette).map_err(io::Error::other)?;
            enc.set_repeat(gif::Repeat::Infinite).map_err(io::Error::other)?;
            self.encoder = Some(enc);
            self.quantizer = Some(nq);
        }
        let (Some(nq), Some(enc)) = (&self.quantizer, &mut self.encoder) else {
            return Err(io::Error::other("GIF encoder not ready"));
        };
        let indices: Vec<u8> = rgba.chunks_exact(4).map(|p| nq.index_of(p).min(254) as u8).collect();

        // Delay of this frame, hundredths of a second, so the sum stays exact.
        let at = |k: u64| (k * 100 + self.fps as u64 / 2) / self.fps as u64;
        let delay = (at(self.count + 1) - at(self.count)).min(u16::MAX as u64) as u16;
        let mut frame = gif::Frame { delay, dispose: gif::DisposalMethod::Keep, ..gif::Frame::default() };
        if self.previous.is_empty() {
            frame.width = self.width;
            frame.height = self.height;
            frame.buffer = indices.as_slice().into();
        } else {
            // The rectangle of changed pixels (at least one pixel).
            let (mut x0, mut y0, mut x1, mut y1) = (w, h, 0, 0);
            for y in 0..h {
                let row = y * w;
                for x in 0..w {
                    if indices[row + x] != self.previous[row + x] {
                        (x0, y0, x1, y1) = (x0.min(x), y0.min(y), x1.max(x + 1), y1.max(y + 1));
                    }
                }
            }
            if x0 >= x1 {
                (x0, y0, x1, y1) = (0, 0, 1, 1);
            }
            let mut buffer = Vec::with_capacity((x1 - x0) * (y1 - y0));
            for y in y0..y1 {
                for x in x0..x1 {
                    let i = y * w + x;
                    buffer.push(if indices[i] == self.previous[i] { TRANSPARENT } else { indices[i] });
                }
            }
            frame.left = x0 as u16;
            frame.top = y0 as u16;
            frame.width = (x1 - x0) as u16;
            frame.height = (y1 - y0) as u16;
            frame.transparent = Some(TRANSPARENT);
            frame.buffer = buffer.into();
        }
        enc.write_frame(&frame).map_err(io::Error::other)?;
        self.previous = indices;
        self.count += 1;
        Ok(())
    }

    /// Ends the file and renames it into place.
    pub fn finish(mut self) -> io::Result<()> {
        let Some(enc) = self.encoder.take() else {
            return Err(io::Error::other("no frames to write"));
        };
        let file = enc.into_inner().map_err(io::Error::other)?;
        let file = file.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        fs::rename(self.tmp.path(), &self.path)?;
        self.tmp.keep();
        Ok(())
    }
}

impl Drop for GifWriter {
    fn drop(&mut self) {
        // Closes the file before `tmp` removes it.
        self.encoder = None;
    }
}

/// How to reach ffmpeg, found by [`find_ffmpeg`].
#[derive(Clone, Debug)]
pub struct Ffmpeg {
    /// The program.
    pub program: String,
    /// Video encoder: `libx264` when ffmpeg has it, else `mpeg4`.
    pub encoder: &'static str,
}

/// ffmpeg on the PATH, or `None` when it cannot be started.
pub fn find_ffmpeg() -> Option<Ffmpeg> {
    let program = "ffmpeg".to_string();
    let out = Command::new(&program).args(["-hide_banner", "-encoders"]).stdin(Stdio::null()).output().ok()?;
    if !out.status.success() {
        return None;
    }
    let list = String::from_utf8_lossy(&out.stdout);
    let encoder = if list.contains(" libx264 ") { "libx264" } else { "mpeg4" };
    Some(Ffmpeg { program, encoder })
}

/// An MP4 made by ffmpeg from raw RGBA frames written to its standard
/// input; ffmpeg writes to a temporary name that is renamed at the end.
pub struct Mp4Writer {
    path: PathBuf,
    tmp: Temporary,
    child: Option<Child>,
    stdin: Option<ChildStdin>,
    stderr: Option<JoinHandle<String>>,
    done: bool,
}

impl Mp4Writer {
    /// Starts ffmpeg for a `width` × `height` video at `fps` (both sides
    /// must be even for the yuv420p pixel format players expect).
    pub fn create(ffmpeg: &Ffmpeg, path: &Path, width: u32, height: u32, fps: u32) -> io::Result<Self> {
        let tmp = Temporary::new(temp_path(path));
        let mut cmd = Command::new(&ffmpeg.program);
        cmd.args(["-hide_banner", "-loglevel", "error", "-nostdin", "-y", "-f", "rawvideo", "-pix_fmt", "rgba"])
            .args(["-s", &format!("{width}x{height}"), "-r", &fps.to_string(), "-i", "-"])
            .args(["-c:v", ffmpeg.encoder, "-pix_fmt", "yuv420p"]);
        if ffmpeg.encoder == "libx264" {
            cmd.args(["-preset", "medium", "-crf", "20"]);
        } else {
            cmd.args(["-q:v", "3"]);
        }
        cmd.args(["-movflags", "+faststart", "-f", "mp4"]).arg(tmp.path());
        let mut child = cmd.stdin(Stdio::piped()).stdout(Stdio::null()).stderr(Stdio::piped()).spawn()?;
        let stdin = child.stdin.take();
        let stderr = child.stderr.take().map(|mut e| {
            std::thread::spawn(move || {
                let mut s = String::new();
                let _ = e.read_to_string(&mut s);
                s
            })
        });
        Ok(Self { path: path.to_path_buf(), tmp, child: Some(child), stdin, stderr, done: false })
    }

    /// ffmpeg's error output so far (after it exited).
    fn ffmpeg_said(&mut self) -> String {
        self.stdin = None;
        if let Some(mut c) = self.child.take() {
            let _ = c.wait();
        }
        let said = self.stderr.take().and_then(|h| h.join().ok()).unwrap_or_default();
        let said = said.trim();
        if said.is_empty() {
            "ffmpeg stopped without a message".into()
        } else {
            format!("ffmpeg: {said}")
        }
    }

    /// Sends the next frame.
    pub fn push(&mut self, rgba: &[u8]) -> io::Result<()> {
        let Some(stdin) = &mut self.stdin else { return Err(io::Error::other("ffmpeg input already closed")) };
        if stdin.write_all(rgba).is_err() {
            return Err(io::Error::other(self.ffmpeg_said()));
        }
        Ok(())
    }

    /// Closes ffmpeg's input, waits for it and renames its output into place.
    pub fn finish(mut self) -> io::Result<()> {
        self.stdin = None;
        let status = match self.child.take() {
            Some(mut c) => c.wait()?,
            None => return Err(io::Error::other("ffmpeg is not running")),
        };
        let said = self.stderr.take().and_then(|h| h.join().ok()).unwrap_or_default();
        if !status.success() {
            return Err(io::Error::other(format!("ffmpeg failed ({status}): {}", said.trim())));
        }
        fs::rename(self.tmp.path(), &self.path)?;
        self.tmp.keep();
        self.done = true;
        Ok(())
    }
}

impl Drop for Mp4Writer {
    fn drop(&mut self) {
        if !self.done {
            self.stdin = None;
            if let Some(mut c) = self.child.take() {
                let _ = c.kill();
                let _ = c.wait();
            }
            // `tmp` removes ffmpeg's unfinished file when dropped.
        }
    }
}

/// Any of the rendered outputs.
pub enum VideoWriter {
    /// `.gif`.
    Gif(GifWriter),
    /// A directory of PNG frames.
    Pngs(PngFrames),
    /// `.mp4` through ffmpeg.
    Mp4(Mp4Writer),
}

impl VideoWriter {
    /// Adds the next frame.
    pub fn push(&mut self, rgba: &[u8]) -> io::Result<()> {
        match self {
            VideoWriter::Gif(g) => g.push(rgba),
            VideoWriter::Pngs(p) => p.push(rgba),
            VideoWriter::Mp4(m) => m.push(rgba),
        }
    }

    /// Completes the output.
    pub fn finish(self) -> io::Result<()> {
        match self {
            VideoWriter::Gif(g) => g.finish(),
            VideoWriter::Pngs(p) => p.finish(),
            VideoWriter::Mp4(m) => m.finish(),
        }
    }
}
