#![no_main]
//! The counts-file readers (JSON and binary, format 4 under the one shard
//! header; the header's numbers are under its fingerprint): any text or
//! bytes either load into counts that evaluate to finite numbers, save and
//! load again to the same counts in both formats, and merge with themselves
//! only as a repeat — or are refused. Never a panic, never an allocation
//! sized by a declared count (libFuzzer's `-rss_limit_mb` catches one).
use itgfx_backends::visibility::VisibilityCounts;
use itgfx_core::Base;
use libfuzzer_sys::fuzz_target;

#[path = "mutate.rs"]
mod mutate;

/// A valid file (`itgfx complexity tetrahedron --lines 12 --blocks 2
/// --save-counts`): random text rarely parses, so each input also edits
/// the numbers of this one.
const TEMPLATE: &str = r#"{"header":{"format":"itgfx-counts","version":4,"shard":0,"shards":1,"fingerprint":"bf3c988257bca4a6","scene":{"name":"tetrahedron","patches":4,"triangles":0,"hash":"e43d8a24adde2fed"},"settings":{"lines":"global","seed":1,"blocks":2,"assignment":"line index mod blocks"}},"areas":[3.4641016151377544,3.4641016151377544,3.4641016151377544,3.4641016151377544],"ranges":[[0,12]],"blocks":[{"lines":6,"segments":3,"escaped":0,"samples":3,"log_sum":"88353198992621494272","log_sq_sum":"175795579957321163776","pairs":[[0,1,2],[0,2,1],[1,0,2],[2,0,1]],"background":[]},{"lines":6,"segments":2,"escaped":0,"samples":2,"log_sum":"8017824994703464448","log_sq_sum":"13500011225033746176","pairs":[[0,3,1],[1,2,1],[2,1,1],[3,0,1]],"background":[]}],"endpoints":[[0,4,"81948454753803220992"],[1,3,"91785714787293233152"],[2,2,"25412622672371736576"],[3,1,"-6404744238818273280"]]}"#;

/// The template with some of its numbers replaced as `data` says.
fn edited(data: &[u8]) -> String {
    mutate::edit_numbers(TEMPLATE, data)
}

/// The template saved as a binary file with some bytes overwritten as
/// `data` says (nine bytes per edit: where, then eight bytes written
/// little-endian there, so a whole size field can become huge).
fn edited_binary(data: &[u8]) -> Vec<u8> {
    let (name, c) = VisibilityCounts::load(TEMPLATE).expect("the template loads");
    let mut b = c.to_binary(&name);
    for e in data.chunks_exact(9) {
        let at = usize::from(e[0]) % b.len();
        let end = (at + 8).min(b.len());
        b[at..end].copy_from_slice(&e[1..1 + end - at]);
    }
    b
}

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        check(VisibilityCounts::load(text));
    }
    check(VisibilityCounts::load(&edited(data)));
    check(VisibilityCounts::from_binary(data));
    check(VisibilityCounts::from_binary(&edited_binary(data)));
});

fn check(loaded: Result<(String, VisibilityCounts), itgfx_backends::visibility::CountsError>) {
    let Ok((name, c)) = loaded else {
        return;
    };
    let e = c.complexity(Base::Bits);
    let m = &e.measures;
    for v in [m.positional_entropy, m.scene_entropy, m.joint_entropy, m.mutual_information] {
        assert!(v.is_finite(), "{v}");
    }
    for v in [e.continuous, e.continuous_stderr, e.mutual_information_stderr, e.mutual_information_corrected] {
        assert!(v.is_none_or(f64::is_finite));
    }
    assert!(e.patch_information.iter().chain(&e.patch_continuous).all(|v| v.is_finite()));
    let mut out = Vec::new();
    c.save(&name, &mut out).unwrap();
    let (again_name, again) = VisibilityCounts::load(std::str::from_utf8(&out).unwrap()).unwrap();
    assert_eq!((&again_name, &again), (&name, &c));
    let (bin_name, bin) = VisibilityCounts::from_binary(&c.to_binary(&name)).unwrap();
    assert_eq!((&bin_name, &bin), (&name, &c));
    let mut twice = c.clone();
    assert!(twice.merge(c.clone()).is_err(), "the same ranges merged twice");
    assert_eq!(twice, c, "a refused merge leaves the counts unchanged");
}
