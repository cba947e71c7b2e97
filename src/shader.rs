//! WGSL composition: modules are concatenated in order, and two directives,
//! each alone on its line, are resolved:
//!
//! - `#if FLAG` / `#if !FLAG`, `#else`, `#endif` (nestable) keep or drop lines
//!   according to the flags set;
//! - `#for_each ITEM in ARRAY` ... `#end_for` repeats its body for every element
//!   of a scene array, with `ITEM` bound to the element and `ITEM_index` to its
//!   index. An array in a storage
//!   buffer becomes a loop; an array baked into the kernel becomes one copy of
//!   the body per element, each reading a module constant, which the driver's
//!   compiler folds into the code (3x faster on lavapipe than a loop over a
//!   constant array, and quicker to compile).
//!
//! Nothing else is rewritten, so what naga validates is what the modules say.

use std::borrow::Cow;
use std::collections::{BTreeMap, BTreeSet};
use std::fmt;

/// One WGSL module: a file from `shaders/`, or text generated from the scene's
/// kinds (`kernel::glue`).
#[derive(Clone, Debug)]
pub struct ShaderModule {
    pub name: &'static str,
    pub source: Cow<'static, str>,
}

/// The module `shaders/NAME.wgsl`, compiled into the binary.
macro_rules! shader_module {
    ($name:literal) => {
        $crate::shader::ShaderModule {
            name: $name,
            source: std::borrow::Cow::Borrowed(include_str!(concat!(
                env!("CARGO_MANIFEST_DIR"),
                "/shaders/",
                $name,
                ".wgsl"
            ))),
        }
    };
}
pub(crate) use shader_module;

/// Where the elements of an array that `#for_each` walks come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum ArrayForm {
    /// A runtime-sized storage buffer of that name: a loop over its
    /// `NAME_count()` elements, each read by `NAME_at` (`kernel::glue`).
    Buffer,
    /// This many module constants named by [`element_constant`].
    Constants(usize),
}

/// The module constant holding element `index` of a baked array: `QUADS_3`.
pub fn element_constant(array: &str, index: usize) -> String {
    format!("{}_{index}", array.to_uppercase())
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

/// What a composition resolves its directives with.
pub struct Directives<'a> {
    /// Flags set for `#if`.
    pub flags: &'a BTreeSet<&'a str>,
    /// Every flag an `#if` may name (catches typos that would otherwise
    /// silently drop code).
    pub known_flags: &'a [&'a str],
    /// The arrays a kept `#for_each` may walk.
    pub arrays: &'a BTreeMap<&'a str, ArrayForm>,
}

/// Concatenates `modules`, resolving their directives.
pub fn compose(modules: &[ShaderModule], directives: &Directives) -> Result<String, ComposeError> {
    let mut out = String::new();
    for module in modules {
        out.push_str(&format!("// ---- {} ----\n", module.name));
        out.push_str(&preprocess(module, directives)?);
    }
    Ok(out)
}

/// An open `#for_each`: its body is collected, then expanded at `#end_for`.
struct ForEach {
    line: usize,
    item: String,
    array: String,
    /// Inside kept lines: expanded, else dropped.
    kept: bool,
    /// `#if` blocks open at the `#for_each`; the body must close its own.
    open_ifs: usize,
    body: String,
}

fn preprocess(module: &ShaderModule, directives: &Directives) -> Result<String, ComposeError> {
    let error = |line: usize, message: String| ComposeError {
        module: module.name.to_string(),
        line,
        message,
    };
    // One entry per open `#if`: (line it opened on, its condition, inside `#else`).
    let mut open: Vec<(usize, bool, bool)> = Vec::new();
    let mut for_each: Option<ForEach> = None;
    let mut out = String::new();
    let kept = |open: &[(usize, bool, bool)]| {
        open.iter()
            .all(|&(_, condition, in_else)| condition != in_else)
    };
    for (index, line) in module.source.lines().enumerate() {
        let number = index + 1;
        let trimmed = line.trim();
        if let Some(rest) = trimmed.strip_prefix("#if ") {
            let rest = rest.trim();
            let (negated, flag) = match rest.strip_prefix('!') {
                Some(flag) => (true, flag.trim()),
                None => (false, rest),
            };
            if !directives.known_flags.contains(&flag) {
                return Err(error(number, format!("unknown flag `{flag}` in `#if`")));
            }
            open.push((number, directives.flags.contains(flag) != negated, false));
        } else if trimmed == "#else" {
            if for_each.as_ref().is_some_and(|f| open.len() == f.open_ifs) {
                return Err(error(
                    number,
                    "`#else` of an `#if` opened before `#for_each`".into(),
                ));
            }
            match open.last_mut() {
                Some((_, _, in_else @ false)) => *in_else = true,
                Some(_) => return Err(error(number, "second `#else` for one `#if`".into())),
                None => return Err(error(number, "`#else` without `#if`".into())),
            }
        } else if trimmed == "#endif" {
            if for_each.as_ref().is_some_and(|f| open.len() == f.open_ifs) {
                return Err(error(
                    number,
                    "`#endif` of an `#if` opened before `#for_each`".into(),
                ));
            }
            if open.pop().is_none() {
                return Err(error(number, "`#endif` without `#if`".into()));
            }
        } else if let Some(rest) = trimmed.strip_prefix("#for_each ") {
            if for_each.is_some() {
                return Err(error(number, "`#for_each` inside `#for_each`".into()));
            }
            let words: Vec<&str> = rest.split_whitespace().collect();
            let [item, "in", array] = words[..] else {
                return Err(error(number, "expected `#for_each ITEM in ARRAY`".into()));
            };
            let active = kept(&open);
            if active && !directives.arrays.contains_key(array) {
                return Err(error(
                    number,
                    format!("array `{array}` is not in this kernel"),
                ));
            }
            for_each = Some(ForEach {
                line: number,
                item: item.to_string(),
                array: array.to_string(),
                kept: active,
                open_ifs: open.len(),
                body: String::new(),
            });
        } else if trimmed == "#end_for" {
            let Some(block) = for_each.take() else {
                return Err(error(number, "`#end_for` without `#for_each`".into()));
            };
            if open.len() != block.open_ifs {
                return Err(error(
                    number,
                    "`#end_for` with an `#if` of its body open".into(),
                ));
            }
            if block.kept {
                out.push_str(&expand(&block, directives.arrays[block.array.as_str()]));
            }
        } else if trimmed.starts_with('#') {
            return Err(error(number, format!("unknown directive `{trimmed}`")));
        } else if kept(&open) {
            let target = match &mut for_each {
                Some(block) => &mut block.body,
                None => &mut out,
            };
            target.push_str(line);
            target.push('\n');
        }
    }
    if let Some(block) = for_each {
        return Err(error(block.line, "`#for_each` without `#end_for`".into()));
    }
    if let Some(&(line, _, _)) = open.last() {
        return Err(error(line, "`#if` without `#endif`".into()));
    }
    Ok(out)
}

/// The body of a `#for_each` once per element, each copy in its own block.
fn expand(block: &ForEach, form: ArrayForm) -> String {
    let ForEach {
        item, array, body, ..
    } = block;
    match form {
        ArrayForm::Buffer => format!(
            "for (var {item}_index = 0u; {item}_index < {array}_count(); {item}_index++) {{\n\
             let {item} = {array}_at({item}_index);\n{body}}}\n"
        ),
        ArrayForm::Constants(count) => (0..count)
            .map(|i| {
                let constant = element_constant(array, i);
                format!("{{\nlet {item}_index = {i}u;\nlet {item} = {constant};\n{body}}}\n")
            })
            .collect(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const KNOWN: &[&str] = &["A", "B"];

    fn run_with(
        source: &'static str,
        flags: &[&'static str],
        arrays: &[(&'static str, ArrayForm)],
    ) -> Result<String, ComposeError> {
        let flags: BTreeSet<&str> = flags.iter().copied().collect();
        let arrays: BTreeMap<&str, ArrayForm> = arrays.iter().copied().collect();
        let module = ShaderModule {
            name: "test",
            source: source.into(),
        };
        let directives = Directives {
            flags: &flags,
            known_flags: KNOWN,
            arrays: &arrays,
        };
        preprocess(&module, &directives)
    }

    fn run(source: &'static str, flags: &[&'static str]) -> Result<String, ComposeError> {
        run_with(source, flags, &[])
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
                source: "1\n".into(),
            },
            ShaderModule {
                name: "two",
                source: "#if A\n2\n#endif\n".into(),
            },
        ];
        let flags: BTreeSet<&str> = ["A"].into_iter().collect();
        let directives = Directives {
            flags: &flags,
            known_flags: KNOWN,
            arrays: &BTreeMap::new(),
        };
        assert_eq!(
            compose(&modules, &directives).unwrap(),
            "// ---- one ----\n1\n// ---- two ----\n2\n"
        );
    }

    const WALK: &str = "a\n#for_each q in quads\nuse(q);\n#if A\nonly_a(q);\n#endif\n#end_for\nb\n";

    #[test]
    fn for_each_over_a_buffer_is_a_loop() {
        assert_eq!(
            run_with(WALK, &[], &[("quads", ArrayForm::Buffer)]).unwrap(),
            "a\nfor (var q_index = 0u; q_index < quads_count(); q_index++) {\n\
             let q = quads_at(q_index);\nuse(q);\n}\nb\n"
        );
    }

    #[test]
    fn for_each_over_constants_repeats_the_body() {
        assert_eq!(
            run_with(WALK, &["A"], &[("quads", ArrayForm::Constants(2))]).unwrap(),
            "a\n{\nlet q_index = 0u;\nlet q = QUADS_0;\nuse(q);\nonly_a(q);\n}\n\
             {\nlet q_index = 1u;\nlet q = QUADS_1;\nuse(q);\nonly_a(q);\n}\nb\n"
        );
        assert_eq!(
            run_with(WALK, &[], &[("quads", ArrayForm::Constants(0))]).unwrap(),
            "a\nb\n"
        );
    }

    #[test]
    fn for_each_in_a_dropped_block_needs_no_array() {
        let source = "#if A\n#for_each s in spheres\nuse(s);\n#end_for\n#endif\nx\n";
        assert_eq!(run(source, &[]).unwrap(), "x\n");
    }

    #[test]
    fn for_each_errors_name_the_line() {
        let error = |source: &'static str| {
            let e = run_with(source, &["A"], &[("quads", ArrayForm::Buffer)]).unwrap_err();
            (e.line, e.message)
        };
        assert_eq!(
            error("x\n#for_each s in spheres\n#end_for\n"),
            (2, "array `spheres` is not in this kernel".to_string())
        );
        assert_eq!(error("#for_each q of quads\n").0, 1);
        assert_eq!(error("#for_each q in quads\n#for_each r in quads\n").0, 2);
        assert_eq!(error("#for_each q in quads\nuse(q);\n").0, 1);
        assert_eq!(error("\n#end_for\n").0, 2);
        assert_eq!(
            error("#for_each q in quads\n#if A\n#end_for\n#endif\n").0,
            3
        );
        assert_eq!(
            error("#if A\n#for_each q in quads\n#endif\n#end_for\n").0,
            3
        );
        assert_eq!(error("#if A\n#for_each q in quads\n#else\n#end_for\n").0, 3);
    }
}
