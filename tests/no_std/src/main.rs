//! Links `itgfx-core` without std and without an allocator, evaluates a few
//! measures on stack data, and returns 0 only if they are right.
#![no_std]
#![no_main]

use core::panic::PanicInfo;

use itgfx_core::{Base, Channel, entropy, huffman_expected_length, kl_divergence};

#[panic_handler]
fn panic(_: &PanicInfo) -> ! {
    loop {}
}

// The C runtime provides the entry point that calls `main`.
#[link(name = "c")]
unsafe extern "C" {}

// The prebuilt `core` for a hosted target names this symbol.
#[unsafe(no_mangle)]
extern "C" fn rust_eh_personality() {}

#[unsafe(no_mangle)]
extern "C" fn main(_argc: i32, _argv: *const *const u8) -> i32 {
    let h = match entropy(&[0.5f64, 0.25, 0.25], Base::Bits) {
        Ok(h) => h,
        Err(_) => return 1,
    };
    if (h - 1.5).abs() > 1e-12 {
        return 2;
    }
    match kl_divergence(&[1.0f32, 0.0], &[0.5, 0.5], Base::Bits) {
        Ok(d) if (d - 1.0).abs() < 1e-6 => {}
        _ => return 3,
    }
    let ch = match Channel::new(&[0.5f64, 0.5], &[1.0, 0.0, 0.0, 1.0], 2) {
        Ok(c) => c,
        Err(_) => return 4,
    };
    if (ch.measures(Base::Bits).mutual_information - 1.0).abs() > 1e-12 {
        return 5;
    }
    let mut scratch = [0.0f64; 4];
    match huffman_expected_length(&[0.5f64, 0.25, 0.125, 0.125], &mut scratch) {
        Ok(l) if (l - 1.75).abs() < 1e-12 => {}
        _ => return 6,
    }
    // Invalid input is an error value, not a panic.
    if entropy(&[f64::NAN], Base::Bits).is_ok() {
        return 7;
    }
    0
}
