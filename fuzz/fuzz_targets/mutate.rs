//! Shared by the targets that edit a valid file: its numbers replaced by
//! values that have broken readers, so a fuzzer reaches the checks behind
//! the parser that random text rarely gets past.
#![allow(dead_code)]

/// Values that have broken readers: zero, signs, 2^32, 2^53, 2^63,
/// 2^64 - 1, past 2^64, huge floats, a tiny one, the fixed-point extremes.
pub const INTERESTING: [&str; 16] = [
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

/// `template` with some of its numbers replaced as `data` says (three
/// bytes per edit: which number, which value, a small offset).
pub fn edit_numbers(template: &str, data: &[u8]) -> String {
    let b = template.as_bytes();
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
    if spans.is_empty() {
        return template.to_string();
    }
    let mut values: Vec<String> = spans.iter().map(|&(s, e)| template[s..e].to_string()).collect();
    for e in data.chunks_exact(3) {
        let i = usize::from(e[0]) % values.len();
        values[i] = match e[1] % 20 {
            v @ 0..16 => INTERESTING[usize::from(v)].to_string(),
            _ => values[i].parse::<i128>().unwrap_or(0).saturating_add(i128::from(e[2] as i8)).to_string(),
        };
    }
    let mut out = String::with_capacity(template.len() + 64);
    let mut last = 0;
    for (&(s, e), v) in spans.iter().zip(&values) {
        out.push_str(&template[last..s]);
        out.push_str(v);
        last = e;
    }
    out.push_str(&template[last..]);
    out
}
