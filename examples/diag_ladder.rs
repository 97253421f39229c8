//! Prototype: does a tolerance ladder make each file's complexes valid?
//! `diag_ladder FILE...`
use portalfind::pipeline::{CellSettings, Subdivision, build_cells_unchecked};
use std::path::PathBuf;

fn main() {
    for f in std::env::args().skip(1) {
        let Ok(m0) = portalfind::model::load_model(std::path::Path::new(&f)) else {
            println!("{f}: refused at load");
            continue;
        };
        for sub in Subdivision::ALL {
            let mut line = format!("{} {sub}:", f.rsplit('/').next().unwrap());
            for k in 0..=3 {
                let mut m = m0.clone();
                let s = 10f64.powi(k);
                m.tolerances.weld *= s;
                m.tolerances.plane *= s;
                m.tolerances.coplanar *= s;
                let r = build_cells_unchecked(&m, &PathBuf::from(&f), &CellSettings::of(sub), &mut |_| {});
                let ok = match r {
                    Err(e) => format!("err {e}"),
                    Ok(c) => match c.cx.check_valid().and(c.cx.validate(&m).map(|_| ())) {
                        Ok(()) => "ok".into(),
                        Err(e) => {
                            let s = e.to_string();
                            s[..s.len().min(40)].to_string()
                        }
                    },
                };
                line += &format!(" L{k}={ok};");
            }
            println!("{line}");
        }
    }
}
