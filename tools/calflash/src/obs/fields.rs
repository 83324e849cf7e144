//! The byte-level pieces both text readers share: splitting a line into fields without
//! allocating, reading a field as a number, and reading a file's body in blocks of whole lines
//! that are parsed on every core and handed back in file order.

use std::io::Read;

use rayon::prelude::*;

/// The most fields a line may hold (more are counted, for the message, but not read).
pub(crate) const MAX_FIELDS: usize = 64;

/// The byte range of each field of a line.
pub(crate) type Spans = [(usize, usize); MAX_FIELDS];

/// Splits a line into `spans` (at each `separator`, a comma or a semicolon, each field
/// trimmed; with none, at runs of spaces and tabs) and returns the number of fields; fields
/// beyond the length of `spans` are counted, not kept.
pub(crate) fn split_bytes(
    bytes: &[u8],
    separator: Option<u8>,
    spans: &mut [(usize, usize)],
) -> usize {
    let mut count = 0;
    let mut keep = |start: usize, end: usize| {
        if let Some(slot) = spans.get_mut(count) {
            *slot = (start, end);
        }
        count += 1;
    };
    let n = bytes.len();
    if let Some(sep) = separator {
        let mut start = 0;
        for end in memchr::memchr_iter(sep, bytes).chain(std::iter::once(n)) {
            let (mut a, mut b) = (start, end);
            while a < b && bytes[a].is_ascii_whitespace() {
                a += 1;
            }
            while b > a && bytes[b - 1].is_ascii_whitespace() {
                b -= 1;
            }
            keep(a, b);
            start = end + 1;
        }
    } else {
        let mut i = 0;
        while i < n {
            while i < n && (bytes[i] == b' ' || bytes[i] == b'\t') {
                i += 1;
            }
            let start = i;
            while i < n && bytes[i] != b' ' && bytes[i] != b'\t' {
                i += 1;
            }
            if i > start {
                keep(start, i);
            }
        }
    }
    count
}

/// The separator of a sample line: a semicolon where there is one (a logger set for a
/// decimal comma writes `1,25;-0,5`), else a comma where there is one, else whitespace.
pub(crate) fn separator_of(bytes: &[u8]) -> Option<u8> {
    if bytes.contains(&b';') {
        Some(b';')
    } else if bytes.contains(&b',') {
        Some(b',')
    } else {
        None
    }
}

/// A field written with a decimal comma (`-0,981`) as a number; `None` otherwise.
#[cold]
pub(crate) fn decimal_comma(field: &[u8]) -> Option<f64> {
    if field.len() > 64 || field.iter().filter(|b| **b == b',').count() != 1 {
        return None;
    }
    let mut buf = [0u8; 64];
    let buf = &mut buf[..field.len()];
    buf.copy_from_slice(field);
    buf.iter_mut()
        .filter(|b| **b == b',')
        .for_each(|b| *b = b'.');
    number(buf)
}

/// Powers of ten that are exact in `f64`, up to the most fraction digits the fast path reads.
const POW10: [f64; 16] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15,
];

/// A field as a number; `None` when it is not a finite number.
///
/// A plain decimal of at most 15 digits (`-123`, `2.252707242`: what loggers and most tools
/// write) is read directly: its digits make an integer `m < 10^15`, exact in `f64`, and
/// `m / 10^k` is then the correctly rounded value (one IEEE division of two exact numbers,
/// Clinger's fast path). Anything else (an exponent, more digits) goes to `fast_float2`.
#[inline]
pub(crate) fn number(field: &[u8]) -> Option<f64> {
    let (negative, rest) = match field {
        [b'-', rest @ ..] => (true, rest),
        [b'+', rest @ ..] => (false, rest),
        _ => (false, field),
    };
    let mut m: u64 = 0;
    let mut digits = 0usize;
    let mut i = 0;
    while let Some(&d) = rest.get(i).filter(|d| d.is_ascii_digit()) {
        m = m.wrapping_mul(10).wrapping_add(u64::from(d - b'0'));
        digits += 1;
        i += 1;
    }
    let mut frac = 0usize;
    if rest.get(i) == Some(&b'.') {
        i += 1;
        while let Some(&d) = rest.get(i).filter(|d| d.is_ascii_digit()) {
            m = m.wrapping_mul(10).wrapping_add(u64::from(d - b'0'));
            digits += 1;
            frac += 1;
            i += 1;
        }
    }
    if i == rest.len() && (1..=15).contains(&digits) {
        // Exact: m < 10^15 < 2^53 (converted as a signed integer, which x86 does in one
        // instruction).
        #[allow(clippy::cast_precision_loss, clippy::cast_possible_wrap)]
        let x = (m as i64) as f64 / POW10[frac];
        return Some(if negative { -x } else { x });
    }
    general(field)
}

/// [`number`] for what its fast path does not read.
#[cold]
#[inline(never)]
fn general(field: &[u8]) -> Option<f64> {
    fast_float2::parse::<f64, _>(field)
        .ok()
        .filter(|x| x.is_finite())
}

/// The longest line of a file's head (preamble, comments, header) that is read: a head line
/// longer than this (a binary file, `/dev/zero`) is refused, named by its number, rather than
/// read on into memory.
pub(crate) const LONGEST_HEAD_LINE: usize = 1 << 20;

/// Reads one line of a file's head into `buf` (appended, its ending kept): the bytes read, 0 at
/// the end of the file. Reads at most [`LONGEST_HEAD_LINE`] + 1 bytes; see [`too_long`].
///
/// # Errors
/// The reader's.
pub(crate) fn read_head_line(
    reader: &mut impl std::io::BufRead,
    buf: &mut Vec<u8>,
) -> std::io::Result<usize> {
    use std::io::BufRead as _;
    reader
        .take(LONGEST_HEAD_LINE as u64 + 1)
        .read_until(b'\n', buf)
}

/// True when the head line in `buf` was cut at [`LONGEST_HEAD_LINE`].
pub(crate) fn too_long(buf: &[u8]) -> bool {
    buf.len() > LONGEST_HEAD_LINE && !buf.ends_with(b"\n")
}

/// Bytes read per block: large enough that a block's parse outweighs handing it to a thread.
const BLOCK: usize = 1 << 20;

/// A "line" this long without a newline (a binary file, say) is parsed as it is, and its
/// fields refused, rather than read on into memory.
const LONGEST_LINE: usize = 256 << 20;

/// Reads `reader` to its end in blocks of whole lines, parses the blocks on every core with
/// `parse(block, lines_before_it)` and hands the results to `merge` in file order; stops at
/// the first error, which is therefore the first in the file. `line` counts the lines before
/// `reader`'s first byte. Three rounds of blocks are in flight at once: one being read, one
/// parsed, one merged; the blocks' buffers are reused.
///
/// # Errors
/// The first error of `parse` or `merge` in file order, or `io`'s for a read that fails.
pub(crate) fn parse_blocks<T: Send, E: Send>(
    reader: &mut (impl Read + Send),
    line: u64,
    parse: impl Fn(&[u8], u64) -> Result<T, E> + Sync,
    mut merge: impl FnMut(T) -> Result<(), E> + Send,
    io: impl Fn(std::io::Error) -> E,
) -> Result<(), E> {
    let per_round = 2 * rayon::current_num_threads();
    let mut blocks = Blocks {
        reader,
        carry: Vec::new(),
        eof: false,
        line,
        spare: Vec::new(),
    };
    let mut current = blocks.round(per_round).map_err(&io)?;
    let mut parsed: Vec<Result<T, E>> = Vec::new();
    // A read that failed, reported once everything before it is merged.
    let mut failed = None;
    while !current.is_empty() || !parsed.is_empty() {
        let read_on = failed.is_none() && !current.is_empty();
        let ((next, fresh), merged) = rayon::join(
            || {
                rayon::join(
                    || read_on.then(|| blocks.round(per_round)),
                    || {
                        current
                            .par_iter()
                            .map(|(block, before)| parse(block, *before))
                            .collect::<Vec<_>>()
                    },
                )
            },
            || parsed.drain(..).try_for_each(|part| merge(part?)),
        );
        merged?;
        blocks.spare.extend(current.drain(..).map(|(buf, _)| buf));
        parsed = fresh;
        match next {
            Some(Ok(round)) => current = round,
            Some(Err(e)) => failed = Some(io(e)),
            None => {}
        }
    }
    failed.map_or(Ok(()), Err)
}

/// Whole-line blocks of a reader, with the line count before each.
struct Blocks<'r, R> {
    reader: &'r mut R,
    /// The start of a line that the last block cut off.
    carry: Vec<u8>,
    eof: bool,
    /// Lines before the next block.
    line: u64,
    /// Buffers of parsed blocks, to be filled again.
    spare: Vec<Vec<u8>>,
}

impl<R: Read> Blocks<'_, R> {
    /// Up to `n` blocks (none at the end of the reader).
    fn round(&mut self, n: usize) -> std::io::Result<Vec<(Vec<u8>, u64)>> {
        let mut out = Vec::with_capacity(n);
        while out.len() < n && !(self.eof && self.carry.is_empty()) {
            let mut buf = self.spare.pop().unwrap_or_default();
            buf.clear();
            buf.append(&mut self.carry);
            let target = buf.len() + BLOCK;
            while !self.eof && buf.len() < target {
                let want = (target - buf.len()) as u64;
                match (&mut *self.reader).take(want).read_to_end(&mut buf) {
                    Ok(0) => self.eof = true,
                    Ok(_) => {}
                    Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                    Err(e) => return Err(e),
                }
            }
            if !self.eof {
                match memchr::memrchr(b'\n', &buf) {
                    Some(p) => {
                        self.carry.extend_from_slice(&buf[p + 1..]);
                        buf.truncate(p + 1);
                    }
                    // No line ends in the block: read on, up to the longest line.
                    None if buf.len() < LONGEST_LINE => {
                        self.carry = buf;
                        continue;
                    }
                    None => {}
                }
            }
            if buf.is_empty() {
                continue;
            }
            let newlines = memchr::memchr_iter(b'\n', &buf).count() as u64;
            out.push((buf, self.line));
            self.line += newlines;
        }
        Ok(out)
    }
}

/// The lines of a block with their numbers (`before` lines precede it), each without its line
/// ending.
pub(crate) fn lines(block: &[u8], before: u64) -> impl Iterator<Item = (u64, &[u8])> {
    let mut rest = block;
    let mut line = before;
    std::iter::from_fn(move || {
        if rest.is_empty() {
            return None;
        }
        let (l, next) = match memchr::memchr(b'\n', rest) {
            Some(p) => (&rest[..p], &rest[p + 1..]),
            None => (rest, &rest[rest.len()..]),
        };
        rest = next;
        line += 1;
        Some((line, l.strip_suffix(b"\r").unwrap_or(l)))
    })
}

/// The line (counted from `before`) of byte `at` of `block`.
pub(crate) fn line_of(block: &[u8], before: u64, at: usize) -> u64 {
    before + 1 + memchr::memchr_iter(b'\n', &block[..at]).count() as u64
}

/// Where a block stops being text: the first NUL byte or byte that is not UTF-8.
pub(crate) fn not_text_at(block: &[u8]) -> Option<usize> {
    let nul = memchr::memchr(0, block);
    let utf8 = std::str::from_utf8(block).err().map(|e| e.valid_up_to());
    match (nul, utf8) {
        (Some(a), Some(b)) => Some(a.min(b)),
        (a, b) => a.or(b),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_semicolon_separates_and_a_decimal_comma_reads() {
        assert_eq!(separator_of(b"0,01;9,81;-0,5"), Some(b';'));
        assert_eq!(separator_of(b"0.01,9.81"), Some(b','));
        assert_eq!(separator_of(b"0.01 9.81"), None);
        let line = b" 0,01 ; 9,81;-0,5 ";
        let mut spans = [(0, 0); 4];
        assert_eq!(split_bytes(line, Some(b';'), &mut spans), 3);
        let fields: Vec<&[u8]> = spans[..3].iter().map(|(a, b)| &line[*a..*b]).collect();
        assert_eq!(fields, [&b"0,01"[..], b"9,81", b"-0,5"]);
        assert_eq!(decimal_comma(b"-0,5"), Some(-0.5));
        assert_eq!(decimal_comma(b"9,81"), Some(9.81));
        assert_eq!(decimal_comma(b"1,2,3"), None);
        assert_eq!(decimal_comma(b"x,1"), None);
    }

    #[test]
    fn blocks_come_back_in_order_with_their_lines() {
        // Lines of every length around the block size, so that blocks end mid-line.
        let mut text = Vec::new();
        let mut want = Vec::new();
        for i in 0..60_000u64 {
            let line = format!("{i},{}\n", "x".repeat((i % 97) as usize));
            text.extend_from_slice(line.as_bytes());
            want.push((i + 1, i));
        }
        text.extend_from_slice(b"60000,no newline at the end");
        want.push((60_001, 60_000));
        let mut got = Vec::new();
        parse_blocks(
            &mut &text[..],
            0,
            |block, before| -> Result<Vec<(u64, u64)>, String> {
                lines(block, before)
                    .map(|(n, l)| {
                        let field = l.split(|&b| b == b',').next().unwrap_or_default();
                        let v = std::str::from_utf8(field).unwrap().parse().unwrap();
                        Ok((n, v))
                    })
                    .collect()
            },
            |part| {
                got.extend(part);
                Ok(())
            },
            |e| e.to_string(),
        )
        .unwrap();
        assert_eq!(got, want);
    }

    #[test]
    fn the_first_error_in_the_file_wins() {
        let text: Vec<u8> = (0..200_000)
            .flat_map(|i| format!("{i}\n").into_bytes())
            .collect();
        let err = parse_blocks(
            &mut &text[..],
            10,
            |block, before| -> Result<(), u64> {
                for (n, l) in lines(block, before) {
                    if l.ends_with(b"7") && n > 50_000 {
                        return Err(n);
                    }
                }
                Ok(())
            },
            |()| Ok(()),
            |_| 0,
        );
        // Line 10 + k holds k - 1; the first k - 1 > 49,989 ending in 7 is 49,997.
        assert_eq!(err, Err(50_008));
    }

    #[test]
    fn numbers_read_as_the_standard_library_reads_them() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            state
        };
        let mut cases: Vec<String> = [
            "0",
            "-0",
            "-0.0",
            "1.",
            ".5",
            "+7",
            "007.250",
            "123456789012345",
            "1234567890123456",
            "0.000000000000001",
            "9.999999999999999",
            "1e5",
            "-2.5E-3",
            "inf",
            "nan",
            "",
            "-",
            ".",
            "1.2.3",
            "12a",
            " 1",
            "0x10",
            "1_000",
        ]
        .iter()
        .map(|s| (*s).to_string())
        .collect();
        for _ in 0..20_000 {
            let digits = 1 + next() % 17;
            let point = next() % (digits + 1);
            let mut s: String = (0..digits)
                .map(|_| char::from(b'0' + (next() % 10) as u8))
                .collect();
            if point < digits {
                s.insert(point as usize, '.');
            }
            if next() % 2 == 0 {
                s.insert(0, '-');
            }
            cases.push(s);
        }
        for s in &cases {
            let want = s.parse::<f64>().ok().filter(|x| x.is_finite());
            let got = number(s.as_bytes());
            assert_eq!(
                got.map(f64::to_bits),
                want.map(f64::to_bits),
                "`{s}`: {got:?} against {want:?}"
            );
        }
    }

    #[test]
    fn text_ends_at_a_nul_or_bad_utf8() {
        assert_eq!(not_text_at(b"abc\n"), None);
        assert_eq!(not_text_at(b"ab\0c"), Some(2));
        assert_eq!(not_text_at(b"a\xffb\0"), Some(1));
        assert_eq!(line_of(b"a\nb\nc", 4, 4), 7);
    }
}
