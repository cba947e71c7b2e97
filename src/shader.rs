//! WGSL composition: modules are concatenated in order, and lines between
//! `#if FLAG` / `#if !FLAG`, `#else` and `#endif` (each alone on its line,
//! nestable) are kept or dropped according to the flags set. Nothing else is
//! rewritten, so what naga validates is what the modules say.

use std::collections::BTreeSet;
use std::fmt;

/// One WGSL source file from `shaders/`.
#[derive(Clone, Copy, Debug)]
pub struct ShaderModule {
    pub name: &'static str,
    pub source: &'static str,
}

#[derive(Clone, Debug, PartialEq, Eq)]
pub struct ComposeError {
    pub module: String,
    /// 1-based line in the module.
    pub line: usize,
    pub message: String,
}

impl fmt::Display for ComposeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "shaders/{}.wgsl:{}: {}",
            self.module, self.line, self.message
        )
    }
}

impl std::error::Error for ComposeError {}

/// Concatenates `modules`, resolving conditional blocks with `flags` set.
/// Every flag a directive names must be in `known` (catches typos that would
/// otherwise silently drop code).
pub fn compose(
    modules: &[ShaderModule],
    flags: &BTreeSet<&str>,
    known: &[&str],
) -> Result<String, ComposeError> {
    let mut out = String::new();
    for module in modules {
        out.push_str(&format!("// ---- {} ----\n", module.name));
        out.push_str(&preprocess(module, flags, known)?);
    }
    Ok(out)
}

fn preprocess(
    module: &ShaderModule,
    flags: &BTreeSet<&str>,
    known: &[&str],
) -> Result<String, ComposeError> {
    let error = |line: usize, message: String| ComposeError {
        module: module.name.to_string(),
        line,
        message,
    };
    // One entry per open `#if`: (line it opened on, its condition, inside `#else`).
    let mut open: Vec<(usize, bool, bool)> = Vec::new();
    let mut out = String::new();
    for (index, line) in module.source.lines().enumerate() {
        let number = index + 1;
        let trimmed = line.trim();
        if let Some(rest) = trimmed.strip_prefix("#if ") {
            let rest = rest.trim();
            let (negated, flag) = match rest.strip_prefix('!') {
                Some(flag) => (true, flag.trim()),
                None => (false, rest),
            };
            if !known.contains(&flag) {
                return Err(error(number, format!("unknown flag `{flag}` in `#if`")));
            }
            open.push((number, flags.contains(flag) != negated, false));
        } else if trimmed == "#else" {
            match open.last_mut() {
                Some((_, _, in_else @ false)) => *in_else = true,
                Some(_) => return Err(error(number, "second `#else` for one `#if`".into())),
                None => return Err(error(number, "`#else` without `#if`".into())),
            }
        } else if trimmed == "#endif" {
            if open.pop().is_none() {
                return Err(error(number, "`#endif` without `#if`".into()));
            }
        } else if trimmed.starts_with('#') {
            return Err(error(number, format!("unknown directive `{trimmed}`")));
        } else if open
            .iter()
            .all(|&(_, condition, in_else)| condition != in_else)
        {
            out.push_str(line);
            out.push('\n');
        }
    }
    if let Some(&(line, _, _)) = open.last() {
        return Err(error(line, "`#if` without `#endif`".into()));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    const KNOWN: &[&str] = &["A", "B"];

    fn run(source: &'static str, flags: &[&'static str]) -> Result<String, ComposeError> {
        let flags: BTreeSet<&str> = flags.iter().copied().collect();
        let module = ShaderModule {
            name: "test",
            source,
        };
        preprocess(&module, &flags, KNOWN)
    }

    #[test]
    fn keeps_and_drops_blocks() {
        let source = "x\n#if A\na\n#else\nnot_a\n#endif\ny\n";
        assert_eq!(run(source, &["A"]).unwrap(), "x\na\ny\n");
        assert_eq!(run(source, &[]).unwrap(), "x\nnot_a\ny\n");
    }

    #[test]
    fn negation_and_nesting() {
        let source = "#if !A\n#if B\nb_only\n#else\nneither\n#endif\n#else\na\n#endif\n";
        assert_eq!(run(source, &["B"]).unwrap(), "b_only\n");
        assert_eq!(run(source, &[]).unwrap(), "neither\n");
        assert_eq!(run(source, &["A", "B"]).unwrap(), "a\n");
    }

    #[test]
    fn inner_blocks_of_a_dropped_block_stay_dropped() {
        let source = "#if A\n#if B\nab\n#endif\n#endif\n";
        assert_eq!(run(source, &["B"]).unwrap(), "");
    }

    #[test]
    fn errors_name_module_and_line() {
        let err = run("ok\n#if C\n#endif\n", &[]).unwrap_err();
        assert_eq!(
            (err.line, err.message.as_str()),
            (2, "unknown flag `C` in `#if`")
        );
        assert_eq!(
            err.to_string(),
            "shaders/test.wgsl:2: unknown flag `C` in `#if`"
        );
        assert_eq!(run("#if A\n", &[]).unwrap_err().line, 1);
        assert_eq!(run("\n#endif\n", &[]).unwrap_err().line, 2);
        assert_eq!(run("#else\n", &[]).unwrap_err().line, 1);
        assert_eq!(
            run("#if A\n#else\n#else\n#endif\n", &[]).unwrap_err().line,
            3
        );
        assert_eq!(run("#ifdef A\n", &[]).unwrap_err().line, 1);
    }

    #[test]
    fn compose_concatenates_in_order() {
        let modules = [
            ShaderModule {
                name: "one",
                source: "1\n",
            },
            ShaderModule {
                name: "two",
                source: "#if A\n2\n#endif\n",
            },
        ];
        let flags: BTreeSet<&str> = ["A"].into_iter().collect();
        assert_eq!(
            compose(&modules, &flags, KNOWN).unwrap(),
            "// ---- one ----\n1\n// ---- two ----\n2\n"
        );
    }
}
