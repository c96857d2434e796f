//! `floor` without a libm call.
//!
//! The default x86-64 target has no SSE4.1 `roundsd`, so `f64::floor` is a call into libm;
//! per-point grid cells and GPS weeks take it millions of times. A cast truncates toward zero
//! exactly below 2⁵², so one step down for a negative non-integer is the floor.

/// `v.floor()`, the same value for every f64 (signed zeros, NaN and infinities included).
#[inline]
pub fn floor_f64(v: f64) -> f64 {
    // 2⁵²: from here on every f64 is an integer.
    if v.abs() < 4_503_599_627_370_496.0 {
        let t = v as i64 as f64;
        if t > v { t - 1.0 } else { t.copysign(v) }
    } else {
        v.floor()
    }
}

/// `v.floor() as i64` (saturating, NaN → 0) without a libm call.
#[inline]
pub fn floor_i64(v: f64) -> i64 {
    floor_f64(v) as i64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn it_is_floor_to_the_bit() {
        let mut vals = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::MAX,
            f64::MIN,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
            f64::EPSILON,
            -f64::EPSILON,
            4_503_599_627_370_496.0,
            -4_503_599_627_370_496.0,
            9.3e18,
            -9.3e18,
            1e30,
            -1e30,
        ];
        for k in -1000i64..1000 {
            let v = k as f64 * 0.25;
            vals.extend([v, v.next_up(), v.next_down()]);
        }
        for e in 0..64 {
            let v = 2f64.powi(e);
            vals.extend([
                v,
                v.next_up(),
                v.next_down(),
                -v,
                (-v).next_up(),
                (-v).next_down(),
            ]);
        }
        let mut s = 0x9e37_79b9_7f4a_7c15_u64;
        for _ in 0..200_000 {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            let v = f64::from_bits(s);
            vals.push(v);
            vals.push((s >> 11) as f64 / (1u64 << 53) as f64 * 2e7 - 1e7);
        }
        for v in vals {
            assert_eq!(floor_f64(v).to_bits(), v.floor().to_bits(), "{v:e}");
            assert_eq!(floor_i64(v), v.floor() as i64, "{v:e}");
        }
    }
}
