//! Value parsers of the flags: each checks its value's range and says what it
//! expected (clap prints the flag's name before the message and exits with 2).

use std::str::FromStr;

use glam::Vec3;
use shadespace::render::targets::SAMPLE_COUNTS;
use shadespace::render::{ClusterDraws, Culling, Exposure, VisibilityMethod};

/// A finite number in `range`, for a flag whose meaning needs one.
fn finite_in(s: &str, range: std::ops::RangeInclusive<f32>, what: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && range.contains(&v) => Ok(v),
        Ok(_) => Err(format!("'{s}' is not {what}")),
        Err(_) => Err(format!("'{s}' is not a number")),
    }
}

/// `--exposure`: `auto` or a positive multiplier.
pub fn exposure(s: &str) -> Result<Exposure, String> {
    if s.trim() == "auto" {
        return Ok(Exposure::Auto);
    }
    let what = "auto or a positive finite number";
    finite_in(s, f32::MIN_POSITIVE..=f32::MAX, what).map(Exposure::Fixed).map_err(|_| format!("'{s}' is not {what}"))
}

/// Comma-separated finite numbers, exactly `N` of them.
fn numbers<const N: usize>(s: &str, form: &str) -> Result<[f32; N], String> {
    let values: Vec<&str> = s.split(',').map(str::trim).collect();
    let bad = || format!("'{s}' is not {form} ({N} finite numbers separated by commas)");
    if values.len() != N {
        return Err(bad());
    }
    let mut out = [0.0; N];
    for (o, v) in out.iter_mut().zip(values) {
        *o = v.parse::<f32>().ok().filter(|x| x.is_finite()).ok_or_else(bad)?;
    }
    Ok(out)
}

/// `--eye`, `--target`: `X,Y,Z`.
pub fn point(s: &str) -> Result<Vec3, String> {
    numbers::<3>(s, "X,Y,Z").map(Vec3::from)
}

/// `--orbit RADIUS,HEIGHT,PERIOD`.
#[derive(Clone, Copy, Debug)]
pub struct Orbit {
    pub radius: f32,
    pub height: f32,
    pub frames: u32,
}

/// `--orbit`: a positive radius, any height, a whole period of at least a frame.
pub fn orbit(s: &str) -> Result<Orbit, String> {
    let [radius, height, period] = numbers::<3>(s, "RADIUS,HEIGHT,PERIOD")?;
    if radius <= 0.0 {
        return Err(format!("'{s}': the radius {radius} is not positive"));
    }
    if period < 1.0 || period.fract() != 0.0 || period > u32::MAX as f32 {
        return Err(format!("'{s}': the period {period} is not a whole number of frames of at least 1"));
    }
    Ok(Orbit { radius, height, frames: period as u32 })
}

/// `--fov`: degrees above 0 and below 180.
pub fn fov_degrees(s: &str) -> Result<f32, String> {
    match s.trim().parse::<f32>() {
        Ok(v) if v.is_finite() && v > 0.0 && v < 180.0 => Ok(v),
        Ok(_) => Err(format!("'{s}' is not a field of view above 0 and below 180 degrees")),
        Err(_) => Err(format!("'{s}' is not a number")),
    }
}

/// A switch that takes `on` or `off`.
pub fn on_off(s: &str) -> Result<bool, String> {
    match s {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err(format!("'{s}' is not on or off")),
    }
}

/// `--visibility`: a method, or `auto` (`None`: chosen once the adapter is known).
#[derive(Clone, Copy, Debug)]
pub struct VisibilityChoice(pub Option<VisibilityMethod>);

/// `--visibility`: `auto`, `raster` or `compute`.
pub fn visibility(s: &str) -> Result<VisibilityChoice, String> {
    match s {
        "auto" => Ok(VisibilityChoice(None)),
        _ => VisibilityMethod::from_str(s)
            .map(|m| VisibilityChoice(Some(m)))
            .map_err(|_| format!("'{s}' is not auto, raster or compute")),
    }
}

/// `--culling`: `none`, `frustum` or `occlusion`.
pub fn culling(s: &str) -> Result<Culling, String> {
    Culling::from_str(s)
}

/// `--cluster-draws`: `indexed` or `list`.
pub fn cluster_draws(s: &str) -> Result<ClusterDraws, String> {
    ClusterDraws::from_str(s)
}

/// `--cull-plain-above`: a share from 0 to 1.
pub fn cull_plain_above(s: &str) -> Result<f32, String> {
    finite_in(s, 0.0..=1.0, "a share of the clusters from 0 to 1")
}

/// `--bloom`: a strength from 0 to 1.
pub fn bloom_strength(s: &str) -> Result<f32, String> {
    finite_in(s, 0.0..=1.0, "a strength from 0 to 1")
}

/// `--views`: the extra views that share the atlas.
#[derive(Clone, Copy, Debug)]
pub enum Views {
    Stereo(f32),
    Fixed,
}

/// `--views`: `stereo:D` (D above 0) or `fixed`.
pub fn views(s: &str) -> Result<Views, String> {
    if s == "fixed" {
        return Ok(Views::Fixed);
    }
    let d = s.strip_prefix("stereo:").ok_or_else(|| format!("'{s}': expected 'stereo:D' or 'fixed'"))?;
    match d.parse::<f32>() {
        Ok(d) if d.is_finite() && d > 0.0 => Ok(Views::Stereo(d)),
        _ => Err(format!("'{d}': the eye distance must be a number above 0")),
    }
}

/// `--shade-hz`, `--frame-hz`: a rate above 0 and at most 1000.
pub fn hertz(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if v.is_finite() && v > 0.0 && v <= 1000.0 {
        Ok(v)
    } else {
        Err(format!("{s} is not a rate above 0 and at most 1000"))
    }
}

/// `--texel-density`: texels per metre above 0, at most 65536.
pub fn texel_density(s: &str) -> Result<f32, String> {
    finite_in(s, f32::MIN_POSITIVE..=65536.0, "a density above 0 and at most 65536 texels per metre")
}

/// `--shade-budget`: millions of texels above 0, at most 1e6.
pub fn shade_budget(s: &str) -> Result<f64, String> {
    let v: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if v.is_finite() && v > 0.0 && v <= 1.0e6 {
        Ok(v)
    } else {
        Err(format!("'{s}' is not a number of millions of texels above 0 and at most 1e6"))
    }
}

/// `--mip-bias`: -16 to 16 levels.
pub fn mip_bias(s: &str) -> Result<f32, String> {
    finite_in(s, -16.0..=16.0, "a bias from -16 to 16 levels")
}

/// `--variable-rate`: 0 to 16 levels.
pub fn variable_rate(s: &str) -> Result<f32, String> {
    finite_in(s, 0.0..=16.0, "a strength from 0 to 16 levels")
}

/// `--level-blend`: 0 to 1 levels.
pub fn level_blend(s: &str) -> Result<f32, String> {
    finite_in(s, 0.0..=1.0, "a band from 0 to 1 levels")
}

/// `--os-aniso`: 1, 2, 4, 8 or 16 taps.
pub fn aniso(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        Ok(n) if shadespace::render::objectspace::ANISO_RATIOS.contains(&n) => Ok(n),
        _ => Err(format!("'{s}' is not one of 1, 2, 4, 8, 16 taps")),
    }
}

/// `--aniso`: 1, 2, 4, 8 or 16 taps of the material textures' sampler.
pub fn texture_aniso(s: &str) -> Result<u16, String> {
    match s.parse::<u16>() {
        Ok(n) if shadespace::render::TEXTURE_ANISOTROPY.contains(&n) => Ok(n),
        _ => Err(format!("'{s}' is not one of 1, 2, 4, 8, 16 taps")),
    }
}

/// `--os-texel-samples`: 1 or 4.
pub fn texel_samples(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        Ok(n @ (1 | 4)) => Ok(n),
        _ => Err(format!("'{s}' is not 1 or 4 samples a texel")),
    }
}

/// `--cap-ms`: a frame time above 0.
pub fn cap_ms(s: &str) -> Result<f64, String> {
    match s.trim().parse::<f64>() {
        Ok(v) if v.is_finite() && v > 0.0 => Ok(v),
        _ => Err(format!("'{s}' is not a frame time above 0 ms")),
    }
}

/// `experiment layers --layers`: a layer count from 1 to 16.
pub fn layer_count(s: &str) -> Result<usize, String> {
    let max = shadespace::materials::MAX_LAYERS;
    match s.trim().parse::<usize>() {
        Ok(k) if (1..=max).contains(&k) => Ok(k),
        _ => Err(format!("'{s}' is not a layer count from 1 to {max}")),
    }
}

/// `--tile-size(s)`: 8, 16, 32 or 64.
pub fn tile_size(s: &str) -> Result<u32, String> {
    match s.parse::<u32>() {
        Ok(t @ (8 | 16 | 32 | 64)) => Ok(t),
        _ => Err(format!("'{s}' is not one of 8, 16, 32, 64")),
    }
}

/// `--os-trimap-lanes`: one of the triangle-map pass's lane counts.
pub fn trimap_lanes(s: &str) -> Result<u32, String> {
    use shadespace::render::objectspace::TRIMAP_LANES;
    match s.parse::<u32>() {
        Ok(n) if TRIMAP_LANES.contains(&n) => Ok(n),
        _ => Err(format!("'{s}' is not 1, 2, 4 or 8 (invocations per texel)")),
    }
}

/// `--os-trimap-store`: 0 or a power of two up to the widest stored level.
pub fn trimap_store(s: &str) -> Result<u32, String> {
    use shadespace::render::objectspace::MAX_TRIMAP_STORE;
    match s.parse::<u32>() {
        Ok(n) if n == 0 || (n.is_power_of_two() && n <= MAX_TRIMAP_STORE) => Ok(n),
        _ => Err(format!("'{s}' is not 0 or a power of two up to {MAX_TRIMAP_STORE} (texels)")),
    }
}

/// `--msaa`: samples per pixel, 1, 2, 4 or 8 (the counts with standard
/// sample positions).
pub fn msaa(s: &str) -> Result<u32, String> {
    match s.trim().parse::<u32>() {
        Ok(n) if SAMPLE_COUNTS.contains(&n) => Ok(n),
        _ => Err(format!("'{s}' is not one of 1, 2, 4, 8 (samples per pixel)")),
    }
}

/// `--size`, `--resolutions`: `WIDTHxHEIGHT`, each from 1 to 16384.
pub fn size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s.split_once(['x', 'X']).ok_or_else(|| format!("'{s}' is not WIDTHxHEIGHT (e.g. 1920x1080)"))?;
    let parse = |v: &str| v.trim().parse::<u32>().ok().filter(|v| (1..=16384).contains(v));
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!("'{s}': width and height must be whole numbers from 1 to 16384")),
    }
}
