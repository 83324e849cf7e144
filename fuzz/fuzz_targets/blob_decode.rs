//! Blob decoding: any bytes, and any payload behind a valid header (first byte odd), give a
//! validated calibration or an error, never a panic. A calibration that decodes re-encodes to a
//! blob that decodes to the same data, and its correction gives finite or flagged outputs.
#![no_main]

use libfuzzer_sys::fuzz_target;
use spincal::blob;
use spincal::model::CalibrationData;
use spincal_fuzz::{exercise, seal};

fuzz_target!(|data: &[u8]| {
    let Some((&mode, rest)) = data.split_first() else {
        return;
    };
    let bytes = if mode & 1 == 1 {
        seal(rest)
    } else {
        rest.to_vec()
    };
    let mut slot = CalibrationData::empty();
    let Ok(cal) = blob::decode_in(&bytes, &mut slot) else {
        return;
    };
    let mut out = vec![0u8; blob::MAX_BLOB_LEN];
    let n = blob::encode(cal, &mut out).expect("a decoded calibration re-encodes");
    let again = blob::decode(&out[..n]).expect("a re-encoded calibration decodes");
    assert_eq!(again.data(), cal.data());
    exercise(cal, rest);
});
