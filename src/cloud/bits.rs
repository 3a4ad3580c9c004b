//! The bit-plane layout of the automaton: one bit per cell, 64 cells to a word along x, rows
//! ordered by (y, z). A plane is a `[u64]` of `rows · words` words; bits past the last cell of
//! a row are always zero, which the shifts rely on and keep.

/// Cell counts and the words per row of a bit plane.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Planes {
    pub nx: usize,
    /// Height layers: y is the vertical axis.
    pub ny: usize,
    pub nz: usize,
    /// Words per row along x.
    pub words: usize,
}

impl Planes {
    pub fn new([nx, ny, nz]: [usize; 3]) -> Planes {
        Planes {
            nx,
            ny,
            nz,
            words: nx.div_ceil(64),
        }
    }

    pub fn cells(&self) -> usize {
        self.nx * self.ny * self.nz
    }

    /// Words in one plane.
    pub fn len(&self) -> usize {
        self.ny * self.nz * self.words
    }

    pub fn is_empty(&self) -> bool {
        self.cells() == 0
    }

    /// Row of layer `j` in slice `k`.
    pub fn row(&self, j: usize, k: usize) -> usize {
        j + self.ny * k
    }

    /// The valid bits of word `w` of a row.
    pub fn mask(&self, w: usize) -> u64 {
        let used = self.nx - 64 * w;
        if used >= 64 {
            u64::MAX
        } else {
            (1u64 << used) - 1
        }
    }

    pub fn get(&self, plane: &[u64], i: usize, j: usize, k: usize) -> bool {
        plane[self.row(j, k) * self.words + i / 64] >> (i % 64) & 1 == 1
    }

    pub fn set(&self, plane: &mut [u64], i: usize, j: usize, k: usize, value: bool) {
        let word = &mut plane[self.row(j, k) * self.words + i / 64];
        let bit = 1u64 << (i % 64);
        if value {
            *word |= bit;
        } else {
            *word &= !bit;
        }
    }

    /// Set bits in a plane.
    pub fn count(plane: &[u64]) -> u64 {
        plane.iter().map(|w| w.count_ones() as u64).sum()
    }

    /// `out[x] = row[x − s]`: the row moved `s` cells towards +x, with zeros entering, or
    /// with the cells leaving one end entering at the other when `wrap`.
    pub fn shift_row(&self, row: &[u64], s: i64, wrap: bool, out: &mut [u64]) {
        let nx = self.nx as i64;
        if wrap && nx > 0 {
            let s = s.rem_euclid(nx);
            shift_clipped(row, s, out);
            if s != 0 {
                let mut rest = [0u64; 64];
                let mut heap;
                let rest: &mut [u64] = if row.len() <= 64 {
                    &mut rest[..row.len()]
                } else {
                    heap = vec![0u64; row.len()];
                    &mut heap
                };
                shift_clipped(row, s - nx, rest);
                for (o, r) in out.iter_mut().zip(rest.iter()) {
                    *o |= r;
                }
            }
        } else {
            shift_clipped(row, s, out);
        }
        if let Some(last) = out.last_mut() {
            *last &= self.mask(row.len() - 1);
        }
    }
}

/// `out[x] = row[x − s]` over whole words, zeros entering; the caller masks the tail.
fn shift_clipped(row: &[u64], s: i64, out: &mut [u64]) {
    let n = row.len() as i64;
    let (q, b) = (s.div_euclid(64), s.rem_euclid(64) as u32);
    for (w, o) in out.iter_mut().enumerate() {
        // Bit x of word w comes from bit x − s: word w − q (low part) and w − q − 1.
        let at = |i: i64| {
            if (0..n).contains(&i) {
                row[i as usize]
            } else {
                0
            }
        };
        let src = w as i64 - q;
        *o = if b == 0 {
            at(src)
        } else {
            (at(src) << b) | (at(src - 1) >> (64 - b))
        };
    }
}
