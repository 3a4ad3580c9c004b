//! A kernel defined here, in a test and nowhere else, runs through hash-consing, the tape and
//! the derivative pass; and kernels are one node exactly when they are equal, also when their
//! hashes collide.

use super::*;
use crate::field::calculus::gradients;
use crate::field::eval::Evaluator;
use crate::field::kernel::noise::Noise;
use crate::field::noise::NoiseKind;
use crate::field::program::Program;

/// `factor · x` of its one argument. Its hash ignores the factor, so every two of them
/// collide and only equality tells them apart.
#[derive(PartialEq, Eq)]
struct Scaled(u32);

impl Hash for Scaled {
    fn hash<H: Hasher>(&self, _state: &mut H) {}
}

impl FieldKernel for Scaled {
    fn outputs(&self) -> usize {
        1
    }

    fn describe(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "scaled by {}", self.0)
    }

    fn run(&self, block: &mut KernelBlock<'_>, args: &[Reg], outs: &[Reg]) {
        let (a, o) = (args[0] as usize * BLOCK, outs[0] as usize * BLOCK);
        for i in 0..block.n {
            block.regs[o + i] = self.0 as f64 * block.regs[a + i];
        }
    }
}

fn scaled(factor: u32) -> NodeRef {
    node::kernel_output(Arc::new(Scaled(factor)), vec![node::position(0)], 0)
}

/// Values of `roots` at the points `(x, 0.5, -2)`, root-major.
fn values(roots: &[NodeRef], xs: &[f64]) -> Vec<Vec<f64>> {
    let program = Program::compile(roots);
    let mut evaluator = Evaluator::new(&program);
    let (ys, zs) = (vec![0.5; xs.len()], vec![-2.0; xs.len()]);
    evaluator.run(xs, &ys, &zs, Precision::Double);
    (0..roots.len())
        .map(|c| evaluator.output(c, xs.len()).to_vec())
        .collect()
}

#[test]
fn equal_kernels_are_one_node_and_different_ones_are_not() {
    let noise = |kind, seed| {
        node::kernel_output(
            Arc::new(Noise { kind, seed }),
            (0..3).map(node::position).collect(),
            0,
        )
    };
    let a = noise(NoiseKind::Perlin, 3);
    assert_eq!(a.id, noise(NoiseKind::Perlin, 3).id);
    assert_ne!(a.id, noise(NoiseKind::Perlin, 4).id);
    assert_ne!(a.id, noise(NoiseKind::Simplex, 3).id);
}

#[test]
fn kernels_whose_hashes_collide_stay_apart() {
    let (two, three) = (scaled(2), scaled(3));
    assert_ne!(two.id, three.id);
    assert_eq!(two.id, scaled(2).id);
    let xs = [0.25, -1.5, 7.0];
    let got = values(&[two, three], &xs);
    for (i, x) in xs.iter().enumerate() {
        assert_eq!(got[0][i], 2.0 * x);
        assert_eq!(got[1][i], 3.0 * x);
    }
}

/// A kernel with no derivative rule of its own is differentiated by central differences of
/// itself; for `3x` those are exact up to rounding: 3 along x, 0 along y and z.
#[test]
fn a_kernel_without_a_derivative_rule_gets_central_differences() {
    let [dx, dy, dz] = gradients(&[scaled(3)]).unwrap().remove(0);
    let got = values(&[dx, dy, dz], &[0.25, -1.5, 1e3]);
    for i in 0..3 {
        assert!((got[0][i] - 3.0).abs() < 1e-9, "{}", got[0][i]);
        assert_eq!((got[1][i], got[2][i]), (0.0, 0.0));
    }
}
