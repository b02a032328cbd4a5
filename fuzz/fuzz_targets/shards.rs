#![no_main]
//! The shard files of `render` and `viewpoints` (and so `volume`, whose shards
//! are viewpoint shards): any text, and valid files with their numbers
//! edited, either load into a shard that validates, survives a save/load round
//! trip unchanged and merges (alone) into an image or is refused in one line —
//! never a panic, never an allocation a declared size asks for. Edited
//! settings no longer match the header's fingerprint, so each edited file is
//! also tried re-stamped (`Header::stamp`), to reach the rows' checks.
use itgfx_backends::render::shard_file::{RenderShard, merge};
use itgfx_backends::shards::{Header, ShardFile};
use itgfx_backends::viewpoint::shard_file::{ViewpointShard, order_shards};
use libfuzzer_sys::fuzz_target;

#[path = "mutate.rs"]
mod mutate;

/// `itgfx render cornell-box --size 3x2 --spp 1 --shard 0/2 --save-shard F`.
const RENDER: &str = r#"{"header":{"format":"itgfx-render-shard","version":3,"shard":0,"shards":2,"fingerprint":"b133ea5b330c4fd4","scene":{"name":"cornell-box","patches":17,"triangles":34,"hash":"10cd12478776eb5b"},"settings":{"sampler":"uniform","spp":1,"max_spp":0,"threshold":null,"unbiased":false,"delta":1.0,"binary_contrast":false,"width":3,"height":2,"seed":1,"camera":[278.0,273.0,15.0,0.0,0.0,0.9999999999999999,0.0,0.9999999999999999,-0.0,0.9424777960769379],"backend":"cpu"}},"first_row":0,"end_row":1,"threshold_used":null,"rgb":[[0.1588512659072876,0.06741072982549667,0.022074496373534203],[0.2801922559738159,0.2853522002696991,0.061313726007938385],[0.043778374791145325,0.02199389971792698,0.006616564001888037]],"samples":[1,1,1],"pilot_samples":[0,0,0]}"#;

/// `itgfx viewpoints tetrahedron --viewpoints 12 --shard 0/4 --save-shard F`.
const VIEWPOINTS: &str = r#"{"header":{"format":"itgfx-viewpoint-shard","version":2,"shard":0,"shards":4,"fingerprint":"a10f343349d89b67","scene":{"name":"tetrahedron","patches":4,"triangles":4,"hash":"eae14cec29f8ef6d"},"settings":{"viewpoints":12,"estimator":"solid-angle","distance":3.0,"levels":[4,8,16,32],"resolution":0,"backend":"cpu"}},"first":0,"end":3,"rows":{"solid-angle":[{"eye":[0.0,-1.5771933363574009,-2.55195242505612],"whole":[[0,0.1153440191388032],[3,0.01081653715885184]],"sampled":[],"base_rays":4,"fractions":[[]]},{"eye":[-1.5771933363574009,-2.55195242505612,0.0],"whole":[[0,0.1153440191388032],[2,0.010816537158851836]],"sampled":[],"base_rays":4,"fractions":[[]]},{"eye":[-2.55195242505612,0.0,-1.5771933363574009],"whole":[[0,0.11534401913880321],[1,0.01081653715885183]],"sampled":[],"base_rays":4,"fractions":[[]]}]}}"#;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        render(text);
        viewpoints(text);
    }
    let edited = mutate::edit_numbers(RENDER, data);
    render(&edited);
    render(&restamp::<RenderShard>(&edited));
    let edited = mutate::edit_numbers(VIEWPOINTS, data);
    viewpoints(&edited);
    viewpoints(&restamp::<ViewpointShard>(&edited));
});

/// `text` with the header's fingerprint recomputed from its scene and
/// settings (unchanged if the header does not parse).
fn restamp<T: ShardFile>(text: &str) -> String {
    let Ok(mut v) = serde_json::from_str::<serde_json::Value>(text) else { return text.to_string() };
    let Ok(h) = serde_json::from_value::<Header<T::Settings>>(v["header"].clone()) else { return text.to_string() };
    v["header"]["fingerprint"] = Header::stamp(&h.scene, &h.settings).into();
    v.to_string()
}

fn one_line(e: &str) {
    assert!(!e.is_empty() && !e.contains('\n'), "{e:?}");
}

fn render(text: &str) {
    let s = match RenderShard::from_json(text) {
        Ok(s) => s,
        Err(e) => return one_line(&e.to_string()),
    };
    assert!(s.validate().is_ok());
    let again = RenderShard::from_json(&s.to_json().unwrap()).unwrap();
    assert_eq!(
        (&again.header, again.first_row, again.end_row, &again.samples),
        (&s.header, s.first_row, s.end_row, &s.samples)
    );
    assert!(again.rgb.iter().flatten().zip(s.rgb.iter().flatten()).all(|(a, b)| (a - b).abs() <= 1e-12 * b.abs()));
    match merge(vec![("a".into(), s.clone())]) {
        Ok((_, frame)) => {
            assert_eq!(s.header.shards, 1, "one shard of several merged");
            assert!(frame.rgb.iter().flatten().all(|v| v.is_finite()));
        }
        Err(e) => one_line(&e.to_string()),
    }
    // The same shard twice is refused.
    assert!(merge(vec![("a".into(), s.clone()), ("b".into(), s)]).is_err());
}

fn viewpoints(text: &str) {
    let s = match ViewpointShard::from_json(text) {
        Ok(s) => s,
        Err(e) => return one_line(&e.to_string()),
    };
    assert!(s.validate().is_ok());
    let again = ViewpointShard::from_json(&s.to_json().unwrap()).unwrap();
    assert_eq!((&again.header, again.len()), (&s.header, s.len()));
    let (scene, settings) = (s.header.scene.clone(), s.header.settings.clone());
    match order_shards(vec![("a".into(), s.clone()), ("b".into(), s)], &scene, &settings) {
        Ok(v) => panic!("the same shard twice ordered into {} shards", v.len()),
        Err(e) => one_line(&e.to_string()),
    }
}
