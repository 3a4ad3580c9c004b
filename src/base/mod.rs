//! What every layer reports and tests with: the failure type and its outcome, and the seeded
//! random numbers tests draw from. It names nothing else in felt.

pub mod failure;
pub mod suggest;
#[cfg(test)]
pub(crate) mod test_random;
pub mod text;
