//! What the property tests share: the statistics they print (worst values and counts), the
//! proptest runner they use and its error plumbing, and the random directions and rotations
//! their cameras and objects are made of.

#![allow(dead_code)]

use std::f64::consts::TAU;

use glam::{DQuat, DVec3};
use proptest::prelude::*;
use proptest::test_runner::{Config, TestCaseError, TestRunner};

#[derive(Debug, Default)]
pub struct Worst {
    values: Vec<(&'static str, f64)>,
    counts: Vec<(&'static str, u64)>,
}

impl Worst {
    pub fn max(&mut self, name: &'static str, value: f64) {
        match self.values.iter_mut().find(|(n, _)| *n == name) {
            Some((_, worst)) => *worst = worst.max(value),
            None => self.values.push((name, value)),
        }
    }

    pub fn count(&mut self, name: &'static str) {
        match self.counts.iter_mut().find(|(n, _)| *n == name) {
            Some((_, count)) => *count += 1,
            None => self.counts.push((name, 1)),
        }
    }

    pub fn print(&self, test: &str) {
        println!("{test}:");
        for (name, value) in &self.values {
            println!("  worst {name}: {value:.3e}");
        }
        for (name, count) in &self.counts {
            println!("  count {name}: {count}");
        }
    }
}

pub fn runner(cases: u32) -> TestRunner {
    TestRunner::new(Config {
        cases,
        failure_persistence: None,
        max_shrink_iters: std::env::var("NO_SHRINK").map_or(1024, |_| 0),
        ..Config::default()
    })
}

pub fn check(result: Result<(), proptest::test_runner::TestError<impl std::fmt::Debug>>) {
    if let Err(error) = result {
        panic!("{error}");
    }
}

pub fn fail(message: String) -> TestCaseError {
    TestCaseError::fail(message)
}

/// Log-uniform in [lo, hi).
pub fn log_uniform(lo: f64, hi: f64) -> impl Strategy<Value = f64> {
    (lo.ln()..hi.ln()).prop_map(f64::exp)
}

/// A uniformly distributed unit vector.
pub fn unit_vector() -> impl Strategy<Value = DVec3> {
    (-1.0..1.0f64, 0.0..TAU).prop_map(|(z, phi): (f64, f64)| {
        let radius = (1.0 - z * z).sqrt();
        DVec3::new(radius * phi.cos(), radius * phi.sin(), z)
    })
}

/// A uniformly distributed rotation axis with a uniform angle.
pub fn rotation() -> impl Strategy<Value = DQuat> {
    (unit_vector(), 0.0..TAU).prop_map(|(axis, angle)| DQuat::from_axis_angle(axis, angle))
}
