//! Arbitrary small LCPs (`n ≤ 6`, entries including NaN, ±∞, huge and subnormal values)
//! through Lemke, PGS and Fischer–Burmeister Newton: construction and every solver
//! return a typed error or a finite solution, never panic.
#![no_main]

use arbitrary::Arbitrary;
use constraint_contact::lcp::{
    fischer_newton, lemke, pgs, Lcp, LemkeSettings, NewtonSettings, PgsSettings,
};
use libfuzzer_sys::fuzz_target;

#[derive(Arbitrary, Debug)]
struct Input {
    n: u8,
    m: Vec<f64>,
    q: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    boxed: bool,
    mu: Option<f64>,
    z0: Vec<f64>,
    warm: Vec<bool>,
}

fn check(r: Result<constraint_contact::lcp::LcpSolution, constraint_contact::lcp::LcpError>) {
    if let Ok(sol) = r {
        assert!(
            sol.z.iter().chain(&sol.w).all(|v| v.is_finite()),
            "non-finite z or w"
        );
        assert!(sol.residual.is_finite(), "non-finite residual");
    }
}

fuzz_target!(|inp: Input| {
    let n = (inp.n % 7) as usize;
    // Dimensions are usually consistent; sometimes the raw (mismatched) vectors.
    let take = |v: &[f64], k: usize| -> Vec<f64> {
        if v.len() >= k && inp.n < 200 {
            v[..k].to_vec()
        } else {
            v.to_vec()
        }
    };
    let m = take(&inp.m, n * n);
    let q = take(&inp.q, n);
    let lcp = if inp.boxed {
        Lcp::boxed(m, q, take(&inp.lo, n), take(&inp.hi, n))
    } else {
        Lcp::new(m, q)
    };
    let Ok(mut lcp) = lcp else {
        return;
    };
    if let Some(mu) = inp.mu {
        let k = lcp.n();
        let links = (0..k)
            .map(|i| (i % 2 == 1).then_some((i - 1, mu)))
            .collect();
        if let Ok(l) = lcp.clone().with_friction(links) {
            lcp = l;
        }
    }
    let z0 = take(&inp.z0, lcp.n());
    let warm: Vec<bool> = inp.warm.iter().copied().take(lcp.n()).collect();
    let quick_pgs = PgsSettings {
        max_iterations: 200,
        ..Default::default()
    };
    check(lemke(&lcp, &LemkeSettings::default(), None));
    check(lemke(&lcp, &LemkeSettings::default(), Some(&warm)));
    check(pgs(&lcp, &quick_pgs, None));
    check(pgs(&lcp, &quick_pgs, Some(&z0)));
    check(fischer_newton(&lcp, &NewtonSettings::default(), None));
    check(fischer_newton(&lcp, &NewtonSettings::default(), Some(&z0)));
});
