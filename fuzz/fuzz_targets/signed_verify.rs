//! Signed blobs: any bytes give a verdict, never a panic; and the signed example with any of
//! its bytes replaced is accepted only when it is the example itself (no forgery: the check is
//! strict Ed25519 over the SHA-256 of the whole blob and the trailer's head).
#![no_main]

use libfuzzer_sys::fuzz_target;
use spincal::model::Serial;
use spincal::signed::{self, StationKey};

static SIGNED: &[u8] = include_bytes!("../../host-tests/golden/imu.signed");
static PUBLIC: &[u8; 32] = include_bytes!("../../host-tests/golden/station.pub");

fuzz_target!(|data: &[u8]| {
    let keys = [StationKey { public: *PUBLIC }];
    let serial = Serial::new("IMU-FULL-0042").expect("a short serial");
    let _ = signed::verify(data, &keys, &serial, 0);
    // Replacements: two bytes of position (modulo the length), one of value, repeated.
    let mut bytes = SIGNED.to_vec();
    for c in data.chunks_exact(3) {
        let at = usize::from(u16::from_le_bytes([c[0], c[1]])) % bytes.len();
        bytes[at] = c[2];
    }
    if signed::verify(&bytes, &keys, &serial, 0).is_ok() {
        assert_eq!(bytes, SIGNED, "a changed signed blob verified");
    }
});
