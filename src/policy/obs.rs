//! Host-side input encoding: observations → convolution patches, missions → token batches.
//!
//! Each view cell is one-hot encoded over [`CELL_CODES`] = 20 codes (11 object types, 6
//! colours, 3 states), so the first layer is equivalent to BabyAI 1.1's embedding of the
//! integer codes. The 3×3 convolution (padding 1) runs as one GEMM over im2col patches built
//! here: observations are constants, so building patches on the host costs nothing in backward.
//! Cells are ordered agent-up: flat index `j = vy·7 + vx` (row 0 farthest ahead, the agent at
//! `j = 45`), so every 49-vector reshapes to the 7×7 picture the displays show.

use std::collections::BTreeMap;

use candle_core::{Device, Tensor};

use super::config::ColourCodes;
use super::error::PolicyError;
use crate::env::view::{Observation, VIEW_SIZE};

/// One-hot codes per cell: 11 object types, then 6 colours, then 3 states.
pub const CELL_CODES: usize = 11 + 6 + 3;

/// Cells in the view.
pub const N_CELLS: usize = VIEW_SIZE * VIEW_SIZE;

/// Length of one im2col patch of a `kernel`×`kernel` convolution: `CELL_CODES × kernel²`,
/// index `c·kernel² + ky·kernel + kx`.
pub const fn patch_len(kernel: usize) -> usize {
    CELL_CODES * kernel * kernel
}

/// Length of one im2col patch of the default 3×3 convolution.
pub const PATCH: usize = patch_len(3);

/// The one-hot codes set for an encoded cell.
#[inline]
fn codes(enc: [u8; 3]) -> [usize; 3] {
    [
        usize::from(enc[0]).min(10),
        11 + usize::from(enc[1]).min(5),
        17 + usize::from(enc[2]).min(2),
    ]
}

/// A code slot left unset ([`ColourCodes::Objects`] on a cell without a colour): the encoder
/// adds no weight column for it.
pub const NO_CODE: u8 = u8::MAX;

/// Object types below this one (unseen, empty, wall) have no colour of their own under
/// [`ColourCodes::Objects`].
const FIRST_COLOURED_TYPE: u8 = 3;

/// The wall's type code: the one type below [`FIRST_COLOURED_TYPE`] that keeps its colour
/// under [`ColourCodes::WallsObjects`].
const WALL_TYPE: u8 = 2;

/// The door's type code: the layout path ([`CellCodes::layout`]) keeps it without its colour.
const DOOR_TYPE: u8 = 4;

/// The carriable objects' type codes (key, ball, box): the layout path keeps none of them.
const FIRST_OBJECT_TYPE: u8 = 5;
const LAST_OBJECT_TYPE: u8 = 7;

/// Appends the 49 patches of the `cell` codes of one frame (49 × 3, as in [`CellCodes`]) for
/// a `kernel`×`kernel` convolution (49 × [`patch_len`]`(kernel)` floats) to `out`.
fn push_patches(cell: &[u8], kernel: usize, out: &mut Vec<f32>) {
    let patch = patch_len(kernel);
    let start = out.len();
    out.resize(start + N_CELLS * patch, 0.0);
    let dst = &mut out[start..];
    let v = VIEW_SIZE as i32;
    let (ks, r) = (kernel as i32, kernel as i32 / 2);
    for vy in 0..v {
        for vx in 0..v {
            let j = (vy * v + vx) as usize;
            // This cell feeds the patch of every neighbour (ny, nx) at kernel offset (ky, kx).
            for ky in 0..ks {
                for kx in 0..ks {
                    let (ny, nx) = (vy - (ky - r), vx - (kx - r));
                    if !(0..v).contains(&ny) || !(0..v).contains(&nx) {
                        continue;
                    }
                    let row = (ny * v + nx) as usize * patch;
                    for &c in cell[j * 3..j * 3 + 3].iter().filter(|&&c| c != NO_CODE) {
                        dst[row + usize::from(c) * (ks * ks) as usize + (ky * ks + kx) as usize] =
                            1.0;
                    }
                }
            }
        }
    }
}

/// The one-hot codes set in every cell of a batch of views: 3 per cell (object type, colour,
/// state, as indices into the [`CELL_CODES`]), cells in the order of [`push_patches`]. The
/// compact form of the patches that [`super::kernels::conv`] reads: 147 bytes per frame instead
/// of 35 KB; cheap to clone.
#[derive(Clone, Debug)]
pub struct CellCodes {
    frames: usize,
    codes: std::sync::Arc<[u8]>,
}

impl CellCodes {
    /// The codes of `obs`.
    pub fn new(obs: &[Observation]) -> Self {
        let mut codes = Vec::with_capacity(obs.len() * N_CELLS * 3);
        for o in obs {
            for vy in 0..VIEW_SIZE {
                for vx in 0..VIEW_SIZE {
                    // Indices below CELL_CODES (< 20), so they fit a byte.
                    codes.extend(self::codes(o.image[vx][vy]).map(|c| c as u8));
                }
            }
        }
        Self {
            frames: obs.len(),
            codes: codes.into(),
        }
    }

    /// The codes the encoder of a model with `colour_codes` reads: these codes themselves for
    /// [`ColourCodes::All`]; for [`ColourCodes::Objects`] the colour slot of unseen, empty and
    /// wall cells is [`NO_CODE`], for [`ColourCodes::WallsObjects`] that of unseen and empty
    /// cells.
    #[must_use]
    pub fn encoded(&self, colour_codes: ColourCodes) -> Self {
        let uncoloured = |t: u8| match colour_codes {
            ColourCodes::All => false,
            ColourCodes::Objects => t < FIRST_COLOURED_TYPE,
            ColourCodes::WallsObjects => t < FIRST_COLOURED_TYPE && t != WALL_TYPE,
        };
        let mut codes = self.codes.to_vec();
        for cell in codes.chunks_exact_mut(3) {
            if uncoloured(cell[0]) {
                cell[1] = NO_CODE;
            }
        }
        Self {
            frames: self.frames,
            codes: codes.into(),
        }
    }

    /// The codes the layout path of a model with [`super::ModelConfig::layout_path`] reads:
    /// a key, ball or box keeps only its state slot (something stands there, which thing is
    /// not said), a door loses its colour (open, closed or locked stays); walls, floor and
    /// empty and unseen cells are as they are.
    #[must_use]
    pub fn layout(&self) -> Self {
        let mut codes = self.codes.to_vec();
        for cell in codes.chunks_exact_mut(3) {
            match cell[0] {
                DOOR_TYPE => cell[1] = NO_CODE,
                t if (FIRST_OBJECT_TYPE..=LAST_OBJECT_TYPE).contains(&t) => {
                    cell[0] = NO_CODE;
                    cell[1] = NO_CODE;
                }
                _ => {}
            }
        }
        Self {
            frames: self.frames,
            codes: codes.into(),
        }
    }

    /// Number of frames.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// `frames × 49 × 3` code indices, frame-major, then cell `j = vy·7 + vx`.
    pub fn as_slice(&self) -> &[u8] {
        &self.codes
    }
}

/// Patches of a batch of frames' codes for a `kernel`×`kernel` convolution as a
/// `(B·49, patch_len(kernel))` tensor: the dense input [`super::model::Net::cells_reference`]
/// multiplies (unset slots, [`NO_CODE`], set nothing).
pub fn patches(codes: &CellCodes, kernel: usize) -> Result<Tensor, PolicyError> {
    let patch = patch_len(kernel);
    let mut data = Vec::with_capacity(codes.frames() * N_CELLS * patch);
    for frame in codes.as_slice().chunks_exact(N_CELLS * 3) {
        push_patches(frame, kernel, &mut data);
    }
    Ok(Tensor::from_vec(
        data,
        (codes.frames() * N_CELLS, patch),
        &Device::Cpu,
    )?)
}

/// Missions of a batch, deduplicated: the text encoder runs once per distinct mission.
#[derive(Clone, Debug)]
pub struct TokenBatch {
    /// `(U, L)` u32 token ids, right-padded with 0.
    pub tokens: Tensor,
    /// `(U, L)` f32, 1 for real words.
    pub mask: Tensor,
    /// Real length of each distinct mission.
    pub lengths: Vec<usize>,
    /// `(B,)` u32: which distinct mission each batch row uses.
    pub index: Tensor,
    /// The distinct token sequences, in `tokens` row order.
    pub distinct: Vec<Vec<u32>>,
    /// Distinct-mission row of each batch row (host copy of `index`).
    pub rows: Vec<usize>,
}

impl TokenBatch {
    /// Builds the batch; every mission needs at least one word.
    pub fn new(missions: &[&[u32]]) -> Result<Self, PolicyError> {
        let mut ids: BTreeMap<&[u32], usize> = BTreeMap::new();
        let mut distinct: Vec<Vec<u32>> = Vec::new();
        let mut rows = Vec::with_capacity(missions.len());
        for m in missions {
            if m.is_empty() {
                return Err(PolicyError::Input(
                    "a mission has no words (MiniGrid's Playground has an empty one): a model \
                     reads a mission of at least one word"
                        .into(),
                ));
            }
            let next = distinct.len();
            let row = *ids.entry(m).or_insert_with(|| {
                distinct.push(m.to_vec());
                next
            });
            rows.push(row);
        }
        let l = distinct.iter().map(Vec::len).max().unwrap_or(1);
        let u = distinct.len();
        let mut tokens = vec![0u32; u * l];
        let mut mask = vec![0f32; u * l];
        for (i, d) in distinct.iter().enumerate() {
            tokens[i * l..i * l + d.len()].copy_from_slice(d);
            mask[i * l..i * l + d.len()]
                .iter_mut()
                .for_each(|x| *x = 1.0);
        }
        let index: Vec<u32> = rows.iter().map(|&r| r as u32).collect();
        Ok(Self {
            tokens: Tensor::from_vec(tokens, (u, l), &Device::Cpu)?,
            mask: Tensor::from_vec(mask, (u, l), &Device::Cpu)?,
            lengths: distinct.iter().map(Vec::len).collect(),
            index: Tensor::from_vec(index, missions.len(), &Device::Cpu)?,
            distinct,
            rows,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patch_centre_holds_the_cell_itself() {
        let mut obs = Observation {
            image: [[[1, 0, 0]; 7]; 7],
        };
        obs.image[2][4] = [6, 3, 0]; // purple ball at vx 2, vy 4
        let codes = CellCodes::new(&[obs]);
        let mut p = Vec::new();
        push_patches(codes.as_slice(), 3, &mut p);
        let row = (4 * 7 + 2) * PATCH;
        let centre = |c: usize| p[row + c * 9 + 4];
        assert_eq!(centre(6), 1.0);
        assert_eq!(centre(11 + 3), 1.0);
        assert_eq!(centre(1), 0.0);
        // Zero padding: the top-left cell's patch has no neighbours above or to the left.
        let top_left = &p[..PATCH];
        assert!((0..CELL_CODES).all(|c| top_left[c * 9] == 0.0 && top_left[c * 9 + 1] == 0.0));
        assert_eq!(p.iter().sum::<f32>() as usize, 3 * (49 * 9 - 4 * 7 * 3 + 4));
        // A 1×1 patch is the cell's own codes and nothing else.
        let mut p1 = Vec::new();
        push_patches(codes.as_slice(), 1, &mut p1);
        assert_eq!(p1.len(), 49 * CELL_CODES);
        let ball = &p1[(4 * 7 + 2) * CELL_CODES..(4 * 7 + 3) * CELL_CODES];
        assert_eq!(
            (ball[6], ball[11 + 3], ball[17], ball[1]),
            (1.0, 1.0, 1.0, 0.0)
        );
        assert_eq!(p1.iter().sum::<f32>() as usize, 3 * 49);
    }

    #[test]
    fn object_colour_codes_leave_floor_walls_and_unseen_cells_without_a_colour() {
        let mut obs = Observation {
            image: [[[1, 0, 0]; 7]; 7], // empty floor: colour 0 is red in MiniGrid's encoding
        };
        obs.image[0][0] = [2, 5, 0]; // grey wall
        obs.image[1][0] = [0, 0, 0]; // unseen
        obs.image[2][4] = [6, 0, 0]; // red ball
        obs.image[3][3] = [5, 5, 0]; // grey key
        let all = CellCodes::new(&[obs]);
        assert_eq!(all.encoded(ColourCodes::All).as_slice(), all.as_slice());
        let objects = all.encoded(ColourCodes::Objects);
        let cell = |c: &CellCodes, vx: usize, vy: usize| {
            let at = (vy * 7 + vx) * 3;
            c.as_slice()[at..at + 3].to_vec()
        };
        assert_eq!(cell(&all, 5, 5), [1, 11, 17], "floor reads red");
        assert_eq!(cell(&objects, 5, 5), [1, NO_CODE, 17]);
        assert_eq!(cell(&objects, 0, 0), [2, NO_CODE, 17]);
        assert_eq!(cell(&objects, 1, 0), [0, NO_CODE, 17]);
        assert_eq!(
            cell(&objects, 2, 4),
            [6, 11, 17],
            "the red ball keeps its colour"
        );
        assert_eq!(
            cell(&objects, 3, 3),
            [5, 16, 17],
            "the grey key keeps its colour"
        );
        // Only the two objects set a colour column in the patches.
        let p = patches(&objects, 1).unwrap().to_vec2::<f32>().unwrap();
        let colour_hits: f32 = p.iter().map(|row| row[11..17].iter().sum::<f32>()).sum();
        assert_eq!(colour_hits, 2.0);
        assert_eq!(p.iter().flatten().sum::<f32>(), (2 * 49 + 2) as f32);
        // Walls and objects: the wall keeps its grey, floor and unseen lose their red.
        let walls = all.encoded(ColourCodes::WallsObjects);
        assert_eq!(cell(&walls, 5, 5), [1, NO_CODE, 17]);
        assert_eq!(cell(&walls, 1, 0), [0, NO_CODE, 17]);
        assert_eq!(cell(&walls, 0, 0), [2, 16, 17], "the wall keeps its grey");
        assert_eq!(cell(&walls, 2, 4), [6, 11, 17]);
        assert_eq!(cell(&walls, 3, 3), [5, 16, 17]);
        let p = patches(&walls, 1).unwrap().to_vec2::<f32>().unwrap();
        let colour_hits: f32 = p.iter().map(|row| row[11..17].iter().sum::<f32>()).sum();
        assert_eq!(colour_hits, 3.0);
    }

    #[test]
    fn cell_codes_match_the_patch_centres() {
        let mut obs = Observation {
            image: [[[1, 0, 0]; 7]; 7],
        };
        obs.image[2][4] = [6, 3, 1];
        let codes = CellCodes::new(&[obs, obs]);
        assert_eq!(codes.frames(), 2);
        assert_eq!(codes.as_slice().len(), 2 * 49 * 3);
        let at = (4 * 7 + 2) * 3;
        assert_eq!(&codes.as_slice()[at..at + 3], &[6, 14, 18]);
        assert_eq!(&codes.as_slice()[..3], &[1, 11, 17]);
    }

    #[test]
    fn token_batch_dedups() {
        let a = [3u32, 4, 2, 11, 9];
        let b = [5u32, 6, 1, 8];
        let tb = TokenBatch::new(&[&a, &b, &a]).unwrap();
        assert_eq!(tb.rows, vec![0, 1, 0]);
        assert_eq!(tb.lengths, vec![5, 4]);
        assert_eq!(tb.tokens.dims(), &[2, 5]);
    }
}
