//! What the property tests share: the statistics they print (worst values and counts), the
//! proptest runner they use, and its error plumbing.

#![allow(dead_code)]

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
