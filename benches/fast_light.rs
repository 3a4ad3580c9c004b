#[path = "light_transport/scenes.rs"]
mod scenes;
use felt::render::settings::RenderSettings;

fn main() {
    let size: usize = std::env::var("SIZE").ok().and_then(|s| s.parse().ok()).unwrap_or(64);
    let spp: u32 = std::env::var("SPP").ok().and_then(|s| s.parse().ok()).unwrap_or(256);
    let only: Option<usize> = std::env::var("ONLY").ok().and_then(|s| s.parse().ok());
    let cells: usize = std::env::var("CELLS").ok().and_then(|s| s.parse().ok()).unwrap_or(32);
    let paths: u32 = std::env::var("PATHS").ok().and_then(|s| s.parse().ok()).unwrap_or(64);
    for (n, scene) in scenes::scenes().iter().enumerate() {
        if only.is_some_and(|o| o != n) { continue; }
        let density = scenes::density(scene);
        let (reference, ref_s) = scenes::render(scene, &density, &scenes::path(scene, size, spp));
        let mut fast = scenes::settings(scene, size);
        fast.indirect = Some(felt::render::indirect::IndirectSettings { cells, paths });
        let (image, fast_s) = scenes::render(scene, &density, &fast);
        let single = RenderSettings { indirect: None, ..scenes::settings(scene, size) };
        let (single_img, _) = scenes::render(scene, &density, &single);
        let (m, r) = scenes::compare(&image, &reference, size);
        let (m1, r1) = scenes::compare(&single_img, &reference, size);
        println!("{}: ref {ref_s:.2}s fast {fast_s:.3}s ({:.1}%) mean {m:.3} rmse {r:.3} | single mean {m1:.3} rmse {r1:.3}", scene.name, 100.0*fast_s/ref_s);
    }
}
