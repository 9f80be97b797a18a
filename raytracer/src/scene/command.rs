//! The in-line commands of scene files (`!xform`, `!genbox`, `!genprism`,
//! `!genrev` and pipes of them), run by the [`Expander`] while it reads
//! scene text: this file sits above the expander and the commands, which
//! read scene text back through it.

use super::rad::{split_command, Expander, RawPrim};
use crate::{Error, Result, SourceLoc};

impl Expander {
    /// Runs one in-line command (`cmd` without its `!`): a pipeline of
    /// `genbox`, `genprism`, `genrev` and `xform` stages.
    pub(super) fn command(
        &mut self,
        cmd: &str,
        loc: &SourceLoc,
        out: &mut Vec<RawPrim>,
    ) -> Result<()> {
        let stages = split_command(cmd).map_err(|bad| {
            Error::parse(
                loc.clone(),
                format!(
                    "command '!{}' uses shell syntax ({bad}); scene files never run shell commands, \
                     only the built-in genbox, genprism, genrev and xform (optionally piped into xform) \
                     are understood",
                    cmd.trim()
                ),
            )
        })?;
        let mut piped: Option<Vec<RawPrim>> = None;
        let n = stages.len();
        for (k, words) in stages.into_iter().enumerate() {
            let Some(prog) = words.first() else {
                return Err(Error::parse(loc.clone(), "empty command in pipeline"));
            };
            let prog_name = prog.rsplit('/').next().unwrap_or(prog);
            let mut stage_out = Vec::new();
            match prog_name {
                "xform" => {
                    super::xform::run_xform(self, &words[1..], piped.take(), loc, &mut stage_out)?;
                }
                "genbox" if k == 0 => {
                    super::genbox::run_genbox(self, &words[1..], loc, &mut stage_out)?;
                }
                "genprism" if k == 0 => {
                    super::generators::run_genprism(self, &words[1..], loc, &mut stage_out)?;
                }
                "genrev" if k == 0 => {
                    super::generators::run_genrev(self, &words[1..], loc, &mut stage_out)?;
                }
                "genbox" | "genprism" | "genrev" => {
                    return Err(Error::parse(
                        loc.clone(),
                        format!("{prog_name} cannot read from a pipe; put it first"),
                    ));
                }
                _ => {
                    return Err(Error::parse(
                        loc.clone(),
                        format!(
                            "refusing to run '!{}': scene files never run shell commands; only the built-in \
                             in-line commands genbox, genprism, genrev and xform are supported (write the generated geometry \
                             into a file instead)",
                            cmd.trim()
                        ),
                    ));
                }
            }
            if k + 1 == n {
                for p in stage_out {
                    out.push(p);
                }
            } else {
                piped = Some(stage_out);
            }
        }
        Ok(())
    }
}
