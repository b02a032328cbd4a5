#![no_main]
//! The counts-file readers (JSON version 2, binary version 3): any text or
//! bytes either load into counts that evaluate to finite numbers, save and
//! load again to the same counts in both formats, and merge with themselves
//! only as a repeat — or are refused. Never a panic, never an allocation
//! sized by a declared count (libFuzzer's `-rss_limit_mb` catches one).
use itgfx_backends::visibility::VisibilityCounts;
use itgfx_core::Base;
use libfuzzer_sys::fuzz_target;

/// A valid file (`itgfx complexity tetrahedron --lines 12 --blocks 2
/// --save-counts`): random text rarely parses, so each input also edits
/// the numbers of this one.
const TEMPLATE: &str = r#"{"format":"itgfx-counts","version":2,"scene":{"name":"tetrahedron","patches":4,"areas_hash":"e43d8a24adde2fed"},"areas":[3.4641016151377544,3.4641016151377544,3.4641016151377544,3.4641016151377544],"lines":"global","seed":1,"ranges":[[0,12]],"jackknife":{"blocks":2,"assignment":"line index mod blocks"},"blocks":[{"lines":6,"segments":3,"escaped":0,"samples":3,"log_sum":"88353198992621490176","log_sq_sum":"175795579957321155584","pairs":[[0,1,2],[0,2,1],[1,0,2],[2,0,1]],"background":[]},{"lines":6,"segments":2,"escaped":0,"samples":2,"log_sum":"8017824994703465472","log_sq_sum":"13500011225033745408","pairs":[[0,3,1],[1,2,1],[2,1,1],[3,0,1]],"background":[]}],"endpoints":[[0,4,"81948454753803217920"],[1,3,"91785714787293229056"],[2,2,"25412622672371736576"],[3,1,"-6404744238818272256"]]}"#;

/// Values that have broken readers: zero, signs, 2^32, 2^53, 2^63,
/// 2^64 - 1, past 2^64, huge floats, a tiny one, the fixed-point extremes.
const INTERESTING: [&str; 16] = [
    "0",
    "1",
    "2",
    "-1",
    "-0.25",
    "4294967296",
    "9007199254740993",
    "9223372036854775808",
    "18446744073709551615",
    "18446744073709551616",
    "999999999999",
    "1e308",
    "1e-310",
    "170141183460469231731687303715884105727",
    "-170141183460469231731687303715884105728",
    "3.4641016151377544",
];

/// The template with some of its numbers replaced as `data` says
/// (three bytes per edit: which number, which value, a small offset).
fn edited(data: &[u8]) -> String {
    let b = TEMPLATE.as_bytes();
    let mut spans = Vec::new();
    let mut k = 0;
    while k < b.len() {
        if b[k].is_ascii_digit() || (b[k] == b'-' && b.get(k + 1).is_some_and(u8::is_ascii_digit)) {
            let s = k;
            k += 1;
            while k < b.len() && (b[k].is_ascii_digit() || b[k] == b'.' || b[k] == b'e') {
                k += 1;
            }
            spans.push((s, k));
        } else {
            k += 1;
        }
    }
    let mut values: Vec<String> = spans.iter().map(|&(s, e)| TEMPLATE[s..e].to_string()).collect();
    for e in data.chunks_exact(3) {
        let i = usize::from(e[0]) % values.len();
        values[i] = match e[1] % 20 {
            v @ 0..16 => INTERESTING[usize::from(v)].to_string(),
            _ => values[i].parse::<i128>().unwrap_or(0).saturating_add(i128::from(e[2] as i8)).to_string(),
        };
    }
    let mut out = String::with_capacity(TEMPLATE.len() + 64);
    let mut last = 0;
    for (&(s, e), v) in spans.iter().zip(&values) {
        out.push_str(&TEMPLATE[last..s]);
        out.push_str(v);
        last = e;
    }
    out.push_str(&TEMPLATE[last..]);
    out
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
