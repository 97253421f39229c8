//! Writes the non-aligned-doors model (thesis fig. 2.13; `portalfind::visibility::doors`)
//! and its ground truth: `cargo run --release --example nonaligned_doors -- [DIR]`
//! (default `models/doors`) writes DIR/nonaligned_doors.obj and .truth.json.

fn main() -> std::io::Result<()> {
    let dir = std::env::args().nth(1).unwrap_or_else(|| "models/doors".into());
    let m = portalfind::visibility::doors::nonaligned_doors();
    portalfind::generate::thesis::write(&m, std::path::Path::new(&dir))?;
    println!(
        "wrote {dir}/{}.obj and .truth.json: {} vertices, {} polygons, {} rooms, {} doorways",
        m.name,
        m.soup.vertices.len(),
        m.soup.polygons.len(),
        m.truth.rooms.len(),
        m.truth.doorways.len()
    );
    Ok(())
}
