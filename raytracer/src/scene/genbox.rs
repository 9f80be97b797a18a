//! Radiance's `genbox`, built in: a box of six polygons from the origin to
//! `(x, y, z)`, named and ordered exactly as genbox(1) writes them (faces
//! `name.1540`, `name.4620`, ... where the digits are corner numbers with bit
//! 1 = x, 2 = y, 4 = z), outward facing unless `-i`.

use super::rad::{Expander, RawPrim};
use crate::{Error, Result, SourceLoc};

/// The six faces as corner numbers, counter-clockwise seen from outside.
const FACES: [[u8; 4]; 6] = [
    [1, 5, 4, 0],
    [4, 6, 2, 0],
    [2, 3, 1, 0],
    [3, 2, 6, 7],
    [5, 1, 3, 7],
    [6, 4, 5, 7],
];

/// Generates the box's polygons (without touching any file).
pub(crate) fn genbox_prims(
    material: &str,
    name: &str,
    size: [f64; 3],
    inward: bool,
    loc: &SourceLoc,
) -> Vec<RawPrim> {
    let corner = |v: u8| {
        [
            if v & 1 != 0 { size[0] } else { 0.0 },
            if v & 2 != 0 { size[1] } else { 0.0 },
            if v & 4 != 0 { size[2] } else { 0.0 },
        ]
    };
    FACES
        .iter()
        .map(|f| {
            let mut order = *f;
            if inward {
                order.reverse();
            }
            RawPrim {
                modifier: material.to_string(),
                ptype: "polygon".to_string(),
                id: format!("{name}.{}{}{}{}", f[0], f[1], f[2], f[3]),
                strs: Vec::new(),
                ints: Vec::new(),
                reals: order.iter().flat_map(|&v| corner(v)).collect(),
                loc: loc.clone(),
                post: None,
            }
        })
        .collect()
}

/// Runs `genbox args` (the words after the program name).
pub(crate) fn run_genbox(
    exp: &mut Expander,
    args: &[String],
    loc: &SourceLoc,
    out: &mut Vec<RawPrim>,
) -> Result<()> {
    const USAGE: &str = "usage: genbox material name xsize ysize zsize [-i] [-r radius | -b bevel]";
    if args.len() < 5 {
        return Err(Error::parse(
            loc.clone(),
            format!("genbox: too few arguments; {USAGE}"),
        ));
    }
    let mut size = [0.0; 3];
    for (k, s) in size.iter_mut().enumerate() {
        let w = &args[2 + k];
        *s = super::rad::parse_real(w)
            .map_err(|r| Error::parse(loc.clone(), format!("genbox: {r}; {USAGE}")))?;
        if *s <= 0.0 {
            return Err(Error::parse(
                loc.clone(),
                format!("genbox: box size {w} must be positive"),
            ));
        }
    }
    let mut inward = false;
    let mut i = 5;
    while i < args.len() {
        match args[i].as_str() {
            "-i" => inward = true,
            "-r" | "-b" => {
                return Err(Error::parse(
                    loc.clone(),
                    format!(
                        "genbox option {}: rounded and bevelled boxes are not implemented; \
                         generate the geometry with Radiance's genbox into a file instead",
                        args[i]
                    ),
                ))
            }
            other => {
                return Err(Error::parse(
                    loc.clone(),
                    format!("genbox: unknown option '{other}'; {USAGE}"),
                ))
            }
        }
        i += 1;
    }
    for p in genbox_prims(&args[0], &args[1], size, inward, loc) {
        exp.push(p, out)?;
    }
    Ok(())
}
