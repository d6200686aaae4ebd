//! `exp(x)` with the bits of the C library's `exp` on x86-64 Linux (glibc since 2.28 on a CPU
//! with FMA, which runs the algorithm of Arm's optimized-routines), one value at a time or four
//! in an AVX2 vector.
//!
//! The kernel activations of eq. 4 are the rollout's main cost: about ten exponentials per
//! sample. `f64::exp` calls the C library, one value per call; this computes the same function,
//! operation for operation (the reduction `x = k ln2 / 128 + r`, `2^(k/128)` from a table of 128
//! entries, a degree-5 polynomial in `r`, the same fused multiply-adds), so that four
//! exponentials take about the time of one call and every DMP result keeps its bits. Written
//! out here, it also stops depending on the machine's C library: the fused multiply-adds are
//! `f64::mul_add` (one instruction with FMA, a correctly rounded software fma without), so the
//! scalar code gives these bits on any machine, FMA or not.
//!
//! The constants are those of that algorithm (the published coefficients, and `ln 2 / 128`
//! split in two); the table holds `2^(i/128)` rounded to f64 and the rounding's relative error,
//! computed to 60 digits (`decimal`: `v = exp(ln2 i / 128)`, `s = float(v)`,
//! `tail = float((v - s) / s)`) and stored as `[bits(tail), bits(s) - (i << 45)]`. The tests
//! check every result against the C library's over every table entry and the special cases.

/// `2^7` table entries.
const TABLE_BITS: u32 = 7;
const N: u64 = 1 << TABLE_BITS;
/// `N / ln 2`.
const INV_LN2_N: f64 = f64::from_bits(0x4067_1547_652b_82fe);
/// `-ln 2 / N` in two parts, the first with its low bits zero.
const NEG_LN2_HI_N: f64 = f64::from_bits(0xbf76_2e42_fefa_0000);
const NEG_LN2_LO_N: f64 = f64::from_bits(0xbd0c_f79a_bc9e_3b3a);
/// `1.5 * 2^52`: added, it rounds `x N / ln 2` to an integer held in the low bits.
const SHIFT: f64 = f64::from_bits(0x4338_0000_0000_0000);
/// The polynomial `e^r - 1 ~ r + C2 r^2 + C3 r^3 + C4 r^4 + C5 r^5`.
const C2: f64 = f64::from_bits(0x3fdf_ffff_ffff_fdbd);
const C3: f64 = f64::from_bits(0x3fc5_5555_5555_543c);
const C4: f64 = f64::from_bits(0x3fa5_5555_cf17_2b91);
const C5: f64 = f64::from_bits(0x3f81_1111_67a4_d017);
/// The top 12 bits (sign and exponent) of `2^-54` and of 512: between them the main path needs
/// no care for overflow, underflow or the last bit of a tiny `x`.
const TOP_TINY: u64 = 0x3c9;
const TOP_BIG: u64 = 0x408;

#[rustfmt::skip]
static TABLE: [u64; 2 * N as usize] = [
    0x0000000000000000, 0x3ff0000000000000, 0x3c9b3b4f1a88bf6e, 0x3feff63da9fb3335,
    0xbc7160139cd8dc5d, 0x3fefec9a3e778061, 0xbc905e7a108766d1, 0x3fefe315e86e7f85,
    0x3c8cd2523567f613, 0x3fefd9b0d3158574, 0xbc8bce8023f98efa, 0x3fefd06b29ddf6de,
    0x3c60f74e61e6c861, 0x3fefc74518759bc8, 0x3c90a3e45b33d399, 0x3fefbe3ecac6f383,
    0x3c979aa65d837b6d, 0x3fefb5586cf9890f, 0x3c8eb51a92fdeffc, 0x3fefac922b7247f7,
    0x3c3ebe3d702f9cd1, 0x3fefa3ec32d3d1a2, 0xbc6a033489906e0b, 0x3fef9b66affed31b,
    0xbc9556522a2fbd0e, 0x3fef9301d0125b51, 0xbc5080ef8c4eea55, 0x3fef8abdc06c31cc,
    0xbc91c923b9d5f416, 0x3fef829aaea92de0, 0x3c80d3e3e95c55af, 0x3fef7a98c8a58e51,
    0xbc801b15eaa59348, 0x3fef72b83c7d517b, 0xbc8f1ff055de323d, 0x3fef6af9388c8dea,
    0x3c8b898c3f1353bf, 0x3fef635beb6fcb75, 0xbc96d99c7611eb26, 0x3fef5be084045cd4,
    0x3c9aecf73e3a2f60, 0x3fef54873168b9aa, 0xbc8fe782cb86389d, 0x3fef4d5022fcd91d,
    0x3c8a6f4144a6c38d, 0x3fef463b88628cd6, 0x3c807a05b0e4047d, 0x3fef3f49917ddc96,
    0x3c968efde3a8a894, 0x3fef387a6e756238, 0x3c875e18f274487d, 0x3fef31ce4fb2a63f,
    0x3c80472b981fe7f2, 0x3fef2b4565e27cdd, 0xbc96b87b3f71085e, 0x3fef24dfe1f56381,
    0x3c82f7e16d09ab31, 0x3fef1e9df51fdee1, 0xbc3d219b1a6fbffa, 0x3fef187fd0dad990,
    0x3c8b3782720c0ab4, 0x3fef1285a6e4030b, 0x3c6e149289cecb8f, 0x3fef0cafa93e2f56,
    0x3c834d754db0abb6, 0x3fef06fe0a31b715, 0x3c864201e2ac744c, 0x3fef0170fc4cd831,
    0x3c8fdd395dd3f84a, 0x3feefc08b26416ff, 0xbc86a3803b8e5b04, 0x3feef6c55f929ff1,
    0xbc924aedcc4b5068, 0x3feef1a7373aa9cb, 0xbc9907f81b512d8e, 0x3feeecae6d05d866,
    0xbc71d1e83e9436d2, 0x3feee7db34e59ff7, 0xbc991919b3ce1b15, 0x3feee32dc313a8e5,
    0x3c859f48a72a4c6d, 0x3feedea64c123422, 0xbc9312607a28698a, 0x3feeda4504ac801c,
    0xbc58a78f4817895b, 0x3feed60a21f72e2a, 0xbc7c2c9b67499a1b, 0x3feed1f5d950a897,
    0x3c4363ed60c2ac11, 0x3feece086061892d, 0x3c9666093b0664ef, 0x3feeca41ed1d0057,
    0x3c6ecce1daa10379, 0x3feec6a2b5c13cd0, 0x3c93ff8e3f0f1230, 0x3feec32af0d7d3de,
    0x3c7690cebb7aafb0, 0x3feebfdad5362a27, 0x3c931dbdeb54e077, 0x3feebcb299fddd0d,
    0xbc8f94340071a38e, 0x3feeb9b2769d2ca7, 0xbc87deccdc93a349, 0x3feeb6daa2cf6642,
    0xbc78dec6bd0f385f, 0x3feeb42b569d4f82, 0xbc861246ec7b5cf6, 0x3feeb1a4ca5d920f,
    0x3c93350518fdd78e, 0x3feeaf4736b527da, 0x3c7b98b72f8a9b05, 0x3feead12d497c7fd,
    0x3c9063e1e21c5409, 0x3feeab07dd485429, 0x3c34c7855019c6ea, 0x3feea9268a5946b7,
    0x3c9432e62b64c035, 0x3feea76f15ad2148, 0xbc8ce44a6199769f, 0x3feea5e1b976dc09,
    0xbc8c33c53bef4da8, 0x3feea47eb03a5585, 0xbc845378892be9ae, 0x3feea34634ccc320,
    0xbc93cedd78565858, 0x3feea23882552225, 0x3c5710aa807e1964, 0x3feea155d44ca973,
    0xbc93b3efbf5e2228, 0x3feea09e667f3bcd, 0xbc6a12ad8734b982, 0x3feea012750bdabf,
    0xbc6367efb86da9ee, 0x3fee9fb23c651a2f, 0xbc80dc3d54e08851, 0x3fee9f7df9519484,
    0xbc781f647e5a3ecf, 0x3fee9f75e8ec5f74, 0xbc86ee4ac08b7db0, 0x3fee9f9a48a58174,
    0xbc8619321e55e68a, 0x3fee9feb564267c9, 0x3c909ccb5e09d4d3, 0x3feea0694fde5d3f,
    0xbc7b32dcb94da51d, 0x3feea11473eb0187, 0x3c94ecfd5467c06b, 0x3feea1ed0130c132,
    0x3c65ebe1abd66c55, 0x3feea2f336cf4e62, 0xbc88a1c52fb3cf42, 0x3feea427543e1a12,
    0xbc9369b6f13b3734, 0x3feea589994cce13, 0xbc805e843a19ff1e, 0x3feea71a4623c7ad,
    0xbc94d450d872576e, 0x3feea8d99b4492ed, 0x3c90ad675b0e8a00, 0x3feeaac7d98a6699,
    0x3c8db72fc1f0eab4, 0x3feeace5422aa0db, 0xbc65b6609cc5e7ff, 0x3feeaf3216b5448c,
    0x3c7bf68359f35f44, 0x3feeb1ae99157736, 0xbc93091fa71e3d83, 0x3feeb45b0b91ffc6,
    0xbc5da9b88b6c1e29, 0x3feeb737b0cdc5e5, 0xbc6c23f97c90b959, 0x3feeba44cbc8520f,
    0xbc92434322f4f9aa, 0x3feebd829fde4e50, 0xbc85ca6cd7668e4b, 0x3feec0f170ca07ba,
    0x3c71affc2b91ce27, 0x3feec49182a3f090, 0x3c6dd235e10a73bb, 0x3feec86319e32323,
    0xbc87c50422622263, 0x3feecc667b5de565, 0x3c8b1c86e3e231d5, 0x3feed09bec4a2d33,
    0xbc91bbd1d3bcbb15, 0x3feed503b23e255d, 0x3c90cc319cee31d2, 0x3feed99e1330b358,
    0x3c8469846e735ab3, 0x3feede6b5579fdbf, 0xbc82dfcd978e9db4, 0x3feee36bbfd3f37a,
    0x3c8c1a7792cb3387, 0x3feee89f995ad3ad, 0xbc907b8f4ad1d9fa, 0x3feeee07298db666,
    0xbc55c3d956dcaeba, 0x3feef3a2b84f15fb, 0xbc90a40e3da6f640, 0x3feef9728de5593a,
    0xbc68d6f438ad9334, 0x3feeff76f2fb5e47, 0xbc91eee26b588a35, 0x3fef05b030a1064a,
    0x3c74ffd70a5fddcd, 0x3fef0c1e904bc1d2, 0xbc91bdfbfa9298ac, 0x3fef12c25bd71e09,
    0x3c736eae30af0cb3, 0x3fef199bdd85529c, 0x3c8ee3325c9ffd94, 0x3fef20ab5fffd07a,
    0x3c84e08fd10959ac, 0x3fef27f12e57d14b, 0x3c63cdaf384e1a67, 0x3fef2f6d9406e7b5,
    0x3c676b2c6c921968, 0x3fef3720dcef9069, 0xbc808a1883ccb5d2, 0x3fef3f0b555dc3fa,
    0xbc8fad5d3ffffa6f, 0x3fef472d4a07897c, 0xbc900dae3875a949, 0x3fef4f87080d89f2,
    0x3c74a385a63d07a7, 0x3fef5818dcfba487, 0xbc82919e2040220f, 0x3fef60e316c98398,
    0x3c8e5a50d5c192ac, 0x3fef69e603db3285, 0x3c843a59ac016b4b, 0x3fef7321f301b460,
    0xbc82d52107b43e1f, 0x3fef7c97337b9b5f, 0xbc892ab93b470dc9, 0x3fef864614f5a129,
    0x3c74b604603a88d3, 0x3fef902ee78b3ff6, 0x3c83c5ec519d7271, 0x3fef9a51fbc74c83,
    0xbc8ff7128fd391f0, 0x3fefa4afa2a490da, 0xbc8dae98e223747d, 0x3fefaf482d8e67f1,
    0x3c8ec3bc41aa2008, 0x3fefba1bee615a27, 0x3c842b94c3a9eb32, 0x3fefc52b376bba97,
    0x3c8a64a931d185ee, 0x3fefd0765b6e4540, 0xbc8e37bae43be3ed, 0x3fefdbfdad9cbe14,
    0x3c77893b4d91cd9d, 0x3fefe7c1819e90d8, 0x3c5305c14160cc89, 0x3feff3c22b8f71f1,
];

/// `exp(x)`: the C library's result, bit for bit, for every `x` (NaN stays NaN, `-inf` gives 0).
#[inline]
pub fn exp(x: f64) -> f64 {
    #[cfg(target_arch = "x86_64")]
    {
        #[target_feature(enable = "fma")]
        fn with_fma(x: f64) -> f64 {
            exp_lane(x)
        }
        if crate::linalg::has_avx2_fma() {
            // SAFETY: the CPU has FMA (checked just above).
            return unsafe { with_fma(x) };
        }
    }
    exp_lane(x)
}

/// [`exp`] inlined into its caller: its fused multiply-adds are instructions where the caller
/// is compiled for FMA, calls of the C library's correctly rounded `fma` elsewhere.
#[inline(always)]
fn exp_lane(x: f64) -> f64 {
    let top = (x.to_bits() >> 52) & 0x7ff;
    if top.wrapping_sub(TOP_TINY) >= TOP_BIG - TOP_TINY {
        return outside(x, top);
    }
    let (tmp, sbits, _) = reduce(x);
    let scale = f64::from_bits(sbits);
    scale.mul_add(tmp, scale)
}

/// `|x| < 2^-54`, `|x| >= 512`, infinities and NaN.
#[cold]
fn outside(x: f64, top: u64) -> f64 {
    if top < TOP_TINY {
        // exp(x) = 1 + x to within half an ulp, rounded as such.
        return 1.0 + x;
    }
    if top >= 0x409 {
        // |x| >= 1024: beyond the range of f64 results, or inf / NaN.
        if x == f64::NEG_INFINITY {
            return 0.0;
        }
        if top == 0x7ff {
            return 1.0 + x;
        }
        return if x.is_sign_negative() {
            0.0
        } else {
            f64::INFINITY
        };
    }
    let (tmp, sbits, ki) = reduce(x);
    if ki & 0x8000_0000 == 0 {
        // k > 0: the scale's exponent may have overflowed by up to 460; scale it back.
        let scale = f64::from_bits(sbits.wrapping_sub(1009 << 52));
        return f64::from_bits(0x7f00_0000_0000_0000) * scale.mul_add(tmp, scale);
    }
    // k < 0: the result may be subnormal; round it to the right precision before scaling it
    // down, so that it is rounded once.
    let scale = f64::from_bits(sbits.wrapping_add(1022 << 52));
    let st = scale * tmp;
    let mut y = scale + st;
    if y < 1.0 {
        let lo = scale - y + st;
        let hi = 1.0 + y;
        let lo = 1.0 - hi + y + lo;
        y = (lo + hi) - 1.0;
        if y == 0.0 {
            y = 0.0;
        }
    }
    f64::from_bits(0x0010_0000_0000_0000) * y
}

/// The reduction and the polynomial: `exp(x) = scale (1 + tmp)` with the bits of `scale`
/// (valid for `-1022 N < k < 1023 N`) and `k`'s bits.
#[inline(always)]
fn reduce(x: f64) -> (f64, u64, u64) {
    let z = x.mul_add(INV_LN2_N, SHIFT);
    let ki = z.to_bits();
    let kd = z - SHIFT;
    let r = kd.mul_add(NEG_LN2_LO_N, kd.mul_add(NEG_LN2_HI_N, x));
    let idx = 2 * (ki % N) as usize;
    let tail = f64::from_bits(TABLE[idx]);
    let sbits = TABLE[idx + 1].wrapping_add(ki << (52 - TABLE_BITS));
    let r2 = r * r;
    let tmp = r4_term(r, r2, r + tail, r2 * r2);
    (tmp, sbits, ki)
}

/// `(r + tail) + r2 (C2 + r C3) + r4 (C4 + r C5)` with its fused multiply-adds.
#[inline(always)]
fn r4_term(r: f64, r2: f64, r_tail: f64, r4: f64) -> f64 {
    let p23 = C3.mul_add(r, C2);
    let p45 = r.mul_add(C5, C4);
    r4.mul_add(p45, p23.mul_add(r2, r_tail))
}

/// [`exp`] of four lanes, for callers compiled for AVX2 and FMA: the same operations lane by
/// lane, so the same bits. Lanes with `|x| < 2^-54` take `1 + x` as [`exp`] does; a vector with
/// any lane of `|x| >= 512`, infinite or NaN is computed lane by lane.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[inline]
pub(crate) fn exp4(x: std::arch::x86_64::__m256d) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::*;
    let c = |v: f64| _mm256_set1_pd(v);
    let bits = _mm256_castpd_si256(x);
    let top = _mm256_and_si256(_mm256_srli_epi64::<52>(bits), _mm256_set1_epi64x(0x7ff));
    let big = _mm256_cmpgt_epi64(top, _mm256_set1_epi64x(TOP_BIG as i64 - 1));
    if _mm256_movemask_pd(_mm256_castsi256_pd(big)) != 0 {
        return exp4_by_lane(x);
    }
    let z = _mm256_fmadd_pd(x, c(INV_LN2_N), c(SHIFT));
    let ki = _mm256_castpd_si256(z);
    let kd = _mm256_sub_pd(z, c(SHIFT));
    let r = _mm256_fmadd_pd(kd, c(NEG_LN2_LO_N), _mm256_fmadd_pd(kd, c(NEG_LN2_HI_N), x));
    // 2 (k mod N), the index of the table's pair.
    let idx = _mm256_slli_epi64::<1>(_mm256_and_si256(ki, _mm256_set1_epi64x(N as i64 - 1)));
    // Each lane's pair `[tail, scale bits]` in one load (shorter than two gathers): lanes 0
    // and 2 in one vector, 1 and 3 in another, then the tails and the scales unpacked.
    let (low, high) = (
        _mm256_castsi256_si128(idx),
        _mm256_extracti128_si256::<1>(idx),
    );
    let at = [
        _mm_cvtsi128_si64(low),
        _mm_extract_epi64::<1>(low),
        _mm_cvtsi128_si64(high),
        _mm_extract_epi64::<1>(high),
    ];
    let pair = |i: usize| {
        // SAFETY: every index is even and below 2 N - 1: the pair is within the table.
        unsafe { _mm_loadu_pd(TABLE.as_ptr().add(at[i] as usize) as *const f64) }
    };
    let (even, odd) = (
        _mm256_set_m128d(pair(2), pair(0)),
        _mm256_set_m128d(pair(3), pair(1)),
    );
    let tail = _mm256_unpacklo_pd(even, odd);
    let sb = _mm256_castpd_si256(_mm256_unpackhi_pd(even, odd));
    let sbits = _mm256_add_epi64(sb, _mm256_slli_epi64::<{ 52 - TABLE_BITS as i32 }>(ki));
    let r2 = _mm256_mul_pd(r, r);
    let p23 = _mm256_fmadd_pd(c(C3), r, c(C2));
    let p45 = _mm256_fmadd_pd(r, c(C5), c(C4));
    let t = _mm256_fmadd_pd(p23, r2, _mm256_add_pd(r, tail));
    let tmp = _mm256_fmadd_pd(_mm256_mul_pd(r2, r2), p45, t);
    let scale = _mm256_castsi256_pd(sbits);
    let e = _mm256_fmadd_pd(scale, tmp, scale);
    let tiny = _mm256_cmpgt_epi64(_mm256_set1_epi64x(TOP_TINY as i64), top);
    _mm256_blendv_pd(e, _mm256_add_pd(c(1.0), x), _mm256_castsi256_pd(tiny))
}

/// [`exp4`] lane by lane, out of its way (so that it stays small enough to be inlined).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2,fma")]
#[cold]
#[inline(never)]
fn exp4_by_lane(x: std::arch::x86_64::__m256d) -> std::arch::x86_64::__m256d {
    use std::arch::x86_64::{_mm256_loadu_pd, _mm256_storeu_pd};
    let mut v = [0.0; 4];
    // SAFETY: `v` holds 4 f64s.
    unsafe { _mm256_storeu_pd(v.as_mut_ptr(), x) };
    let v = v.map(exp_lane);
    // SAFETY: as above.
    unsafe { _mm256_loadu_pd(v.as_ptr()) }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The C library's `exp` is the truth where it runs this algorithm: glibc on x86-64 with FMA.
    fn libc_is_the_truth() -> bool {
        cfg!(all(
            target_os = "linux",
            target_env = "gnu",
            target_arch = "x86_64"
        )) && crate::linalg::has_avx2_fma()
    }

    /// Arguments over the whole range, every table entry among them, and the edges.
    fn arguments() -> Vec<f64> {
        let mut v = vec![
            0.0,
            -0.0,
            1e-300,
            -1e-300,
            5e-324,
            2f64.powi(-54),
            -(2f64.powi(-54)),
            2f64.powi(-55),
            511.999,
            512.0,
            -512.0,
            700.0,
            709.78,
            709.79,
            710.0,
            -708.0,
            -708.4,
            -709.0,
            -730.0,
            -744.0,
            -745.1,
            -746.0,
            1023.9,
            1024.0,
            -1024.0,
            1e10,
            -1e10,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MAX,
            f64::MIN,
            f64::NAN,
        ];
        // A deterministic sweep: a linear congruential generator over several scales.
        let mut s: u64 = 0x9e37_79b9_7f4a_7c15;
        for i in 0..400_000 {
            s = s
                .wrapping_mul(6_364_136_223_846_793_005)
                .wrapping_add(1_442_695_040_888_963_407);
            let u = (s >> 11) as f64 / (1u64 << 53) as f64;
            let scale = [1e-3, 1.0, 40.0, 745.0, 1100.0][i % 5];
            v.push((2.0 * u - 1.0) * scale);
        }
        // The exponents of the kernels of eq. 4 and every multiple of ln 2 / 128 near them.
        for k in -6000..200 {
            let x = k as f64 * std::f64::consts::LN_2 / 128.0;
            v.extend([x, x.next_up(), x.next_down()]);
        }
        v
    }

    #[test]
    fn gives_the_c_librarys_bits() {
        if !libc_is_the_truth() {
            return;
        }
        for x in arguments() {
            let (want, got) = (x.exp(), exp(x));
            assert!(
                want.to_bits() == got.to_bits() || (want.is_nan() && got.is_nan()),
                "exp({x:e}) = {got:e}, the C library's {want:e}"
            );
        }
    }

    /// Where the C library runs another algorithm, the result is still within an ulp.
    #[test]
    fn is_within_an_ulp() {
        for x in arguments() {
            let (want, got) = (x.exp(), exp(x));
            if want.is_nan() {
                assert!(got.is_nan());
            } else if want.is_infinite() {
                assert_eq!(got, want, "exp({x:e})");
            } else if want.is_finite() && want > 1e-300 {
                assert!((got - want).abs() <= 2.3e-16 * want, "exp({x:e})");
            } else {
                assert!((got - want).abs() <= 1e-300, "exp({x:e})");
            }
        }
    }

    #[cfg(target_arch = "x86_64")]
    #[test]
    fn vectors_give_the_scalar_bits() {
        use std::arch::x86_64::{_mm256_loadu_pd, _mm256_storeu_pd};
        if !crate::linalg::has_avx2_fma() {
            return;
        }
        let args = arguments();
        // Special lanes inside vectors of ordinary ones, and the other way round.
        for chunk in args.chunks_exact(4).chain(args[3..].chunks_exact(4)) {
            let mut out = [0.0; 4];
            // SAFETY: the CPU has AVX2 and FMA (checked above); the arrays hold 4 f64s.
            unsafe { _mm256_storeu_pd(out.as_mut_ptr(), exp4(_mm256_loadu_pd(chunk.as_ptr()))) };
            for (x, e) in chunk.iter().zip(out) {
                let want = exp(*x);
                assert!(
                    want.to_bits() == e.to_bits() || (want.is_nan() && e.is_nan()),
                    "exp4({x:e})"
                );
            }
        }
    }
}
