//! Renders a built-in scene at a few moments and reports the time per frame.
//!
//! ```sh
//! cargo run --release -p crumble-render --example render_scene -- brick_wall 1280x720 0,0.3,1.0 /tmp/out
//! ```
//!
//! Arguments: scene name, image size, comma-separated times in seconds, and
//! optionally a directory to write `SCENE_T.png` images into.

use std::time::Instant;

use crumble_render::{Renderer, SceneFrames};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let name = args.first().map_or("brick_wall", String::as_str);
    let (w, h) = args
        .get(1)
        .and_then(|s| s.split_once('x'))
        .and_then(|(a, b)| Some((a.parse().ok()?, b.parse().ok()?)))
        .unwrap_or((1280u32, 720u32));
    let times: Vec<f64> = args.get(2).map_or(vec![0.0], |s| s.split(',').filter_map(|t| t.parse().ok()).collect());
    let out = args.get(3);

    let scene = crumble_scene::builtin::find(name).ok_or("no such built-in scene")?;
    let mut sim = crumble_scene::build(&crumble_scene::parse(scene.source, name)?)?;
    let frames = SceneFrames::new(&sim.bodies);
    let camera = frames.auto_camera(w as f32 / h as f32, 45.0);
    let t0 = Instant::now();
    let env = |k: &str, d: u32| std::env::var(k).ok().and_then(|v| v.parse().ok()).unwrap_or(d);
    let options = crumble_render::RendererOptions {
        msaa_samples: env("CRUMBLE_MSAA", 4),
        shadow_map_size: env("CRUMBLE_SHADOW", 2048),
    };
    let mut renderer = Renderer::with_options(options)?;
    println!("{} bodies; adapter {}; set-up {:.0} ms", sim.bodies.len(), renderer.describe(), ms(t0));
    for t in times {
        while sim.time() + 1e-9 < t {
            sim.step()?;
        }
        let frame = frames.frame_of(&sim)?;
        let mut best = f64::MAX;
        let mut image = renderer.render_rgba(&frame, &camera, w, h)?;
        let (cpu0, runs) = (cpu_ms(), 5);
        for _ in 0..runs {
            let start = Instant::now();
            image = renderer.render_rgba(&frame, &camera, w, h)?;
            best = best.min(ms(start));
        }
        let cpu = (cpu_ms() - cpu0) / runs as f64;
        println!("t = {t:.2} s: {w}x{h} in {best:.1} ms wall (best of {runs}), {cpu:.0} ms CPU (all threads, mean)");
        if let Some(dir) = out {
            let path = std::path::Path::new(dir).join(format!("{name}_{t:.2}.png"));
            let mut enc = png::Encoder::new(std::io::BufWriter::new(std::fs::File::create(&path)?), w, h);
            enc.set_color(png::ColorType::Rgba);
            enc.set_depth(png::BitDepth::Eight);
            enc.write_header()?.write_image_data(&image)?;
        }
    }
    Ok(())
}

/// CPU time of this process so far (user + system, all threads), ms; 0
/// where /proc is not there.
fn cpu_ms() -> f64 {
    let stat = std::fs::read_to_string("/proc/self/stat").unwrap_or_default();
    let fields: Vec<&str> = stat.rsplit(')').next().unwrap_or("").split_whitespace().collect();
    let ticks: f64 = fields.get(11..13).map_or(0.0, |f| f.iter().filter_map(|x| x.parse::<f64>().ok()).sum());
    ticks * 10.0 // USER_HZ is 100 on Linux
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}
