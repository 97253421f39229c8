//! The pictures: the top view draws cells (a run that leaves one giant cell and spikes reads
//! as such), multi-storey models get a side view, and the weight curve carries its markers.

use portalfind::decimate::{Estimator, HeuristicKind, StopRule};
use portalfind::output::{CellDoc, Locator, Notes, svg};
use portalfind::pipeline::{self, Settings};
use std::path::PathBuf;

fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

/// A result of four_room_optimized whose cells are rearranged into one giant cell and the
/// five smallest convex pieces as cells of their own ("spikes").
#[test]
fn giant_cell_and_five_spikes_look_like_it() {
    let tm = portalfind::generate::thesis::by_name("four_room_optimized").unwrap();
    let dir = std::env::temp_dir().join(format!("portalfind-pictures-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    portalfind::generate::thesis::write(&tm, &dir).unwrap();
    let mut s = Settings::default();
    s.decimation.heuristic = HeuristicKind::Refined;
    s.decimation.estimator = Estimator::Hull;
    s.decimation.stop = StopRule::Cells(4);
    let (model, run) = pipeline::run(&dir.join("four_room_optimized.obj"), &s, &mut |_| {}).unwrap();
    let mut doc = run.doc.clone();
    let mut pieces: Vec<_> = doc.cells.iter().flat_map(|c| c.pieces.clone()).collect();
    pieces.sort_by(|a, b| a.volume.total_cmp(&b.volume));
    let rest = pieces.split_off(5);
    let mut cells: Vec<CellDoc> = pieces
        .into_iter()
        .map(|p| CellDoc {
            id: p.source_cell,
            volume: p.volume,
            pieces: vec![p],
        })
        .collect();
    cells.push(CellDoc {
        id: rest.iter().map(|p| p.source_cell).min().unwrap(),
        volume: rest.iter().map(|p| p.volume).sum(),
        pieces: rest,
    });
    cells.sort_by_key(|c| c.id);
    let giant = cells.iter().max_by(|a, b| a.volume.total_cmp(&b.volume)).unwrap().id;
    doc.cells = cells;
    let notes = Notes {
        truth: Some(&tm.truth),
        ..Default::default()
    };
    let text = svg::cells_svg_with(&model, &doc, &notes);
    // Every cell is drawn, with its id as a tooltip.
    assert_eq!(text.matches("<title>cell ").count(), 6);
    assert!(
        text.contains(&format!("largest cell {giant} holds 9")),
        "giant cell named"
    );
    // The legend says which cells hold no room: the spikes (those holding no sample).
    let loc = Locator::new(&doc);
    let held: Vec<u32> = tm
        .truth
        .rooms
        .iter()
        .flat_map(|r| r.samples.iter().filter_map(|p| loc.locate(p)).map(|c| c.0))
        .collect();
    let spikes = doc.cells.iter().filter(|c| !held.contains(&c.id)).count();
    assert!(spikes >= 4, "{spikes}");
    assert_eq!(text.matches("no room (spike)").count(), spikes);
    assert!(text.contains(&format!("{spikes} cells hold none of their samples")));
    assert!(text.contains("rooms A+B+C+D"), "the giant cell holds all four rooms");
    // Spikes are outlined so that they stay visible, and the truth and a scale bar are drawn.
    assert_eq!(
        text.matches(r##"stroke="#000" stroke-width="1.2"><title>cell"##)
            .count(),
        5
    );
    assert!(text.contains("room sample point (truth)") && text.contains("model units"));
    // Without notes: the same cells, no truth.
    let plain = svg::cells_svg(&model, &doc);
    assert_eq!(plain.matches("<title>cell ").count(), 6);
    assert!(!plain.contains("room sample point"));
    std::fs::remove_dir_all(&dir).unwrap();
}

/// e1m1's floors lie at several heights, so its top view gets a side view; the four rooms'
/// single floor does not.
#[test]
fn multi_storey_models_get_a_side_view() {
    let e1m1 = portalfind::model::load_model(&repo().join("models/quake/e1m1.obj")).unwrap();
    assert!(svg::multi_storey(&e1m1));
    let tm = portalfind::generate::thesis::by_name("four_room_optimized").unwrap();
    let polys = tm.soup.polygons.clone();
    let m = portalfind::model::from_soup("four", tm.soup.vertices.clone(), polys).unwrap();
    assert!(!svg::multi_storey(&m));
}

/// Storeys come from the cells' floor heights: a generated multi-storey building (the
/// suite's `multistorey` family) splits into at least two storeys, every cell in exactly
/// one, each storey's cells with floors in its band; `cells.svg` draws one top view per
/// storey besides the whole top view and the side view. The single-floor four rooms get
/// one storey and no slices.
#[test]
fn multi_storey_buildings_get_one_top_view_per_storey() {
    let case = portalfind::suite::suite()
        .into_iter()
        .find(|c| c.name.starts_with("multistorey"))
        .expect("a multistorey suite case");
    let model = case.load().unwrap();
    assert!(svg::multi_storey(&model), "{}", case.name);
    let mut s = Settings::default();
    s.decimation.heuristic = HeuristicKind::Aperture;
    s.decimation.stop = HeuristicKind::Aperture.default_stop();
    let run = pipeline::run_model(&model, std::path::Path::new(&case.name), &s, Vec::new(), &mut |_| {}).unwrap();
    let doc = &run.doc;
    let st = svg::storeys(doc);
    assert!(st.len() >= 2, "{}: {} storeys", case.name, st.len());
    let mut all: Vec<usize> = st.iter().flat_map(|x| x.cells.clone()).collect();
    all.sort_unstable();
    assert_eq!(all, (0..doc.cells.len()).collect::<Vec<_>>());
    for (k, x) in st.iter().enumerate() {
        assert!(x.floor < x.next, "storey {k}: {} .. {}", x.floor, x.next);
        for &i in &x.cells {
            let floor = doc.cells[i]
                .pieces
                .iter()
                .flat_map(|p| p.vertices.iter().map(|v| v[2]))
                .fold(f64::INFINITY, f64::min);
            assert!(
                floor >= x.floor && floor < x.next,
                "cell {i} floor {floor} in storey {k}"
            );
        }
        if k > 0 {
            assert_eq!(st[k - 1].next, x.floor);
        }
    }
    let text = svg::cells_svg(&model, doc);
    for k in 1..=st.len() {
        assert!(text.contains(&format!("storey {k} of {}", st.len())), "panel {k}");
    }
    assert!(text.contains("side view"));
    // Each cell is drawn in the top view, in its storey's view and in the side view.
    assert_eq!(text.matches("<title>cell ").count(), 3 * doc.cells.len());

    let tm = portalfind::generate::thesis::by_name("four_room_optimized").unwrap();
    let m = portalfind::model::from_soup("four", tm.soup.vertices.clone(), tm.soup.polygons.clone()).unwrap();
    let run = pipeline::run_model(&m, std::path::Path::new("four"), &s, Vec::new(), &mut |_| {}).unwrap();
    assert_eq!(svg::storeys(&run.doc).len(), 1);
    assert!(!svg::cells_svg(&m, &run.doc).contains("storey 1 of"));
}
