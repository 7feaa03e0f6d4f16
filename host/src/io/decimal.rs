//! Reading a number from a CSV cell: the f64 nearest its decimal value, as `fast_float2`
//! gives it, in a fraction of the time for the short decimals a ride is made of.
//!
//! `fast_float2` reads every form (exponents, `inf`, long mantissas) and spends about 200
//! instructions on a cell; a ride's cells are a sign, at most 19 digits and a point,
//! which the exact fast path (Clinger, 1990) reads in a few instructions a digit: when
//! the digits, as an integer `w`, are at most 2^53 and there are `f <= 22` after the
//! point, `w` and `10^f` are exact f64 values and one IEEE division rounds `w / 10^f`
//! correctly, so the result is the correctly rounded one `fast_float2` gives, bit for bit.
//! Any other cell goes to `fast_float2`. No crate offers the fast path alone.

/// The powers of ten an f64 holds exactly.
const POW10: [f64; 23] = [
    1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
    1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
];
/// Digits read by the fast path, at most (their integer fits in a u64).
const MAX_DIGITS: usize = 19;
/// The largest integer below which every integer is an exact f64.
const MAX_EXACT: u64 = 1 << 53;

/// The f64 nearest the number `cell` writes (the whole cell, no white space around it),
/// as `fast_float2::parse` reads it; `None` when it is not a number.
pub fn parse_f64(cell: &[u8]) -> Option<f64> {
    exact_decimal(cell).or_else(|| fast_float2::parse::<f64, _>(cell).ok())
}

/// The fast path alone: `[-]digits[.digits]` within the exact range, else `None`.
pub fn exact_decimal(cell: &[u8]) -> Option<f64> {
    leading_decimal(cell)
        .filter(|&(_, used)| used == cell.len())
        .map(|(value, _)| value)
}

/// The fast path's number at the start of `text` and the bytes it takes: `[-]digits
/// [.digits]`, read up to the first byte that cannot continue it, within the exact range;
/// `None` when no such number starts `text`. A cell that ends where the number does
/// reads as [`exact_decimal`] reads it (it is that function), so a line's cells can be
/// read where they start, without being cut out first.
pub fn leading_decimal(text: &[u8]) -> Option<(f64, usize)> {
    let negative = text.first() == Some(&b'-');
    let start = usize::from(negative);
    let (mut mantissa, mut end) = digit_run(text, start, 0);
    let mut count = end - start;
    let mut fraction = 0;
    if text.get(end) == Some(&b'.') {
        (mantissa, end) = digit_run(text, end + 1, mantissa);
        fraction = end - (start + count + 1);
        count += fraction;
    }
    if count == 0 || count > MAX_DIGITS || mantissa > MAX_EXACT {
        return None;
    }
    let value = mantissa as f64 / POW10[fraction];
    Some((if negative { -value } else { value }, end))
}

/// The unsigned integer of at most 19 digits (`MAX_DIGITS`) at the start of `text` and the
/// digits it takes; `None` when `text` does not start with a digit or the integer is
/// longer.
pub fn leading_integer(text: &[u8]) -> Option<(u64, usize)> {
    let (value, end) = digit_run(text, 0, 0);
    (end > 0 && end <= MAX_DIGITS).then_some((value, end))
}

/// `mantissa` followed by the digits of `text` from `start` on, and where they end.
/// Wrapping: callers refuse more than [`MAX_DIGITS`] digits after the walk.
fn digit_run(text: &[u8], start: usize, mut mantissa: u64) -> (u64, usize) {
    let mut i = start;
    while let Some(d) = text
        .get(i)
        .map(|b| b.wrapping_sub(b'0'))
        .filter(|d| *d <= 9)
    {
        mantissa = mantissa.wrapping_mul(10).wrapping_add(u64::from(d));
        i += 1;
    }
    (mantissa, i)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    /// Random u64s from `seed`: the same cells on every run.
    fn seeded(seed: u64) -> impl FnMut() -> u64 {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        move || rng.random()
    }

    fn same(cell: &str) {
        let ours = parse_f64(cell.as_bytes());
        let theirs = fast_float2::parse::<f64, _>(cell).ok();
        assert_eq!(ours.map(f64::to_bits), theirs.map(f64::to_bits), "{cell:?}");
    }

    #[test]
    fn every_cell_reads_as_fast_float2_reads_it_bit_for_bit() {
        for cell in [
            "0",
            "-0",
            "0.0",
            "-0.000",
            "1.",
            ".5",
            "-.5",
            "00012.50",
            "0.1",
            "0.2",
            "0.3",
            "9.80665",
            "-0.255448",
            "1718030736.872695300",
            "9007199254740992",
            "9007199254740993",
            "12345678901234567890",
            "1234567890123456789",
            "0.0000000000000000000001",
            "0.00000000000000000000001",
            "1e3",
            "1E-3",
            "-2.5e+2",
            "inf",
            "-infinity",
            "nan",
            "NaN",
            "",
            "-",
            ".",
            "-.",
            "1.2.3",
            "+5",
            "5+",
            "1,5",
            " 1",
            "1 ",
            "0x10",
            "--1",
            "1e",
            "3.14159265358979323846",
        ] {
            same(cell);
        }
        // Random decimals of the lengths loggers write, and at the fast path's edges.
        let mut next = seeded(0x9e37_79b9_7f4a_7c15u64);
        for _ in 0..200_000 {
            let digits = 1 + (next() % 19) as usize;
            let mut cell: String = (0..digits)
                .map(|_| char::from(b'0' + (next() % 10) as u8))
                .collect();
            let point = (next() % (digits as u64 + 1)) as usize;
            cell.insert(point, '.');
            if next() % 2 == 0 {
                cell.insert(0, '-');
            }
            same(&cell);
        }
    }

    #[test]
    fn a_number_read_where_it_starts_is_the_cell_read_whole() {
        let mut next = seeded(0x2545_f491_4f6c_dd1du64);
        let alphabet = b"0123456789.-,;e ";
        for _ in 0..200_000 {
            let len = (next() % 24) as usize;
            let cell: Vec<u8> = (0..len)
                .map(|_| alphabet[(next() % alphabet.len() as u64) as usize])
                .filter(|b| *b != b',' && *b != b';')
                .collect();
            // A cell, then a delimiter and more: the leading number is the cell's when
            // it takes the whole cell, and a number never reads past its end.
            let mut line = cell.clone();
            line.extend(b",1.5");
            let whole = exact_decimal(&cell).map(f64::to_bits);
            let leading = leading_decimal(&line).filter(|&(_, used)| used == cell.len());
            assert_eq!(leading.map(|(v, _)| v.to_bits()), whole, "{cell:?}");
            if let Some((_, used)) = leading_decimal(&line) {
                assert!(used <= cell.len(), "{cell:?}");
            }
        }
        assert_eq!(leading_decimal(b"-0.25,3"), Some((-0.25, 5)));
        assert_eq!(leading_decimal(b"12\r"), Some((12.0, 2)));
        assert_eq!(leading_decimal(b",1"), None);
        assert_eq!(
            leading_integer(b"1718030736872718943,0.1"),
            Some((1718030736872718943, 19))
        );
        assert_eq!(leading_integer(b"17180307368727189430"), None);
        assert_eq!(leading_integer(b"-5"), None);
        assert_eq!(leading_integer(b"0"), Some((0, 1)));
    }

    #[test]
    fn the_fast_path_takes_rides_cells_and_leaves_the_rest() {
        assert_eq!(exact_decimal(b"-0.255448"), Some(-0.255448));
        assert_eq!(exact_decimal(b"3599.998"), Some(3599.998));
        assert_eq!(exact_decimal(b"1e3"), None);
        assert_eq!(exact_decimal(b"9007199254740993"), None);
        assert_eq!(parse_f64(b"1e3"), Some(1000.0));
        assert_eq!(parse_f64(b"x"), None);
    }
}
