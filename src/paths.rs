//! Which of a command's paths name the same file: checked before any work, so
//! that no output overwrites an input or another output; and how every file a
//! command or a scene names is opened for reading ([`open_input`]).
//!
//! Two paths are the same file when they resolve to one device and inode
//! (symlinks followed, hard links included), or, for a file that does not exist
//! yet, to the same file name in the same canonical folder.

use std::fs::File;
use std::io::{self, Read};
use std::path::{Path, PathBuf};

/// Opens a file to read: only a regular file (symlinks followed). A FIFO would
/// block forever waiting for a writer, and a device such as `/dev/zero` never
/// ends, so neither is opened as a scene, a mesh, an image or any file they
/// name. Returns the file and its length when opened.
pub fn open_input(path: &Path) -> io::Result<(File, u64)> {
    let mut options = std::fs::OpenOptions::new();
    options.read(true);
    // Without a writer, opening a FIFO blocks; non-blocking, it opens at once
    // and is refused below (a regular file reads the same either way).
    #[cfg(unix)]
    std::os::unix::fs::OpenOptionsExt::custom_flags(&mut options, libc::O_NONBLOCK);
    let file = options.open(path)?;
    let metadata = file.metadata()?;
    if !metadata.is_file() {
        return Err(io::Error::new(
            io::ErrorKind::InvalidInput,
            format!("not a regular file ({})", file_kind(&metadata)),
        ));
    }
    Ok((file, metadata.len()))
}

/// The whole of a regular file (see [`open_input`]), at most as long as it was
/// when opened.
pub fn read_input(path: &Path) -> io::Result<Vec<u8>> {
    let (file, length) = open_input(path)?;
    read_at_most(file, length)
}

/// At most the first `limit` bytes of a regular file (see [`open_input`]): what
/// a format declares, never more, however long the file.
pub fn read_input_prefix(path: &Path, limit: u64) -> io::Result<Vec<u8>> {
    let (file, length) = open_input(path)?;
    read_at_most(file, length.min(limit))
}

/// A regular file's text (see [`open_input`]), which must be UTF-8.
pub fn read_input_text(path: &Path) -> io::Result<String> {
    String::from_utf8(read_input(path)?)
        .map_err(|_| io::Error::new(io::ErrorKind::InvalidData, "the file is not UTF-8 text"))
}

fn read_at_most(file: File, limit: u64) -> io::Result<Vec<u8>> {
    let mut bytes = Vec::with_capacity(usize::try_from(limit).unwrap_or(0));
    file.take(limit).read_to_end(&mut bytes)?;
    Ok(bytes)
}

/// What a file that is not a regular file is, for a message.
fn file_kind(metadata: &std::fs::Metadata) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        let kind = metadata.file_type();
        if kind.is_fifo() {
            return "a named pipe";
        }
        if kind.is_char_device() || kind.is_block_device() {
            return "a device";
        }
        if kind.is_socket() {
            return "a socket";
        }
    }
    if metadata.is_dir() {
        "a folder"
    } else {
        "not a file that can be read to its end"
    }
}

/// Whether a command reads or writes a path.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Role {
    Input,
    Output,
}

/// One path a command takes, with a label naming it in messages (its flag,
/// or a setting's name).
#[derive(Clone, Debug)]
pub struct PathUse<L> {
    pub label: L,
    pub path: PathBuf,
    pub role: Role,
}

impl<L> PathUse<L> {
    pub fn input(label: L, path: &Path) -> PathUse<L> {
        PathUse {
            label,
            path: path.to_owned(),
            role: Role::Input,
        }
    }

    pub fn output(label: L, path: &Path) -> PathUse<L> {
        PathUse {
            label,
            path: path.to_owned(),
            role: Role::Output,
        }
    }
}

/// Two uses of one file, at least one of them written.
#[derive(Clone, Debug)]
pub struct Collision<L> {
    pub first: PathUse<L>,
    pub second: PathUse<L>,
}

impl<L> Collision<L> {
    /// The same collision, its uses labelled by `relabel`.
    pub fn relabel<M>(self, relabel: impl Fn(L) -> M) -> Collision<M> {
        let relabel_use = |u: PathUse<L>| PathUse {
            label: relabel(u.label),
            path: u.path,
            role: u.role,
        };
        Collision {
            first: relabel_use(self.first),
            second: relabel_use(self.second),
        }
    }
}

impl<L: std::fmt::Display> std::fmt::Display for Collision<L> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let (a, b) = (&self.first, &self.second);
        let what = match (a.role, b.role) {
            (Role::Output, Role::Output) => "both would be written to it".to_string(),
            (Role::Input, _) => format!("{} would overwrite what {} reads", b.label, a.label),
            (_, Role::Input) => format!("{} would overwrite what {} reads", a.label, b.label),
        };
        write!(
            f,
            "{} `{}` and {} `{}` are the same file ({what}): give each its own path",
            a.label,
            a.path.display(),
            b.label,
            b.path.display()
        )
    }
}

/// What identifies a file on this machine.
#[derive(Clone, Debug, PartialEq, Eq)]
enum FileKey {
    /// An existing file: device and inode.
    Inode(u64, u64),
    /// A file to be made: its canonical folder and its name.
    Planned(PathBuf),
}

/// Most symlinks followed to a file that does not exist (as Linux's `ELOOP`).
const MAX_LINKS: usize = 40;

fn key(path: &Path) -> io::Result<FileKey> {
    let mut path = path.to_owned();
    for _ in 0..MAX_LINKS {
        match std::fs::metadata(&path) {
            Ok(metadata) => return Ok(inode(&path, &metadata)),
            Err(e) if e.kind() != io::ErrorKind::NotFound => return Err(e),
            Err(_) => {}
        }
        let folder = match path.parent() {
            Some(parent) if !parent.as_os_str().is_empty() => parent.to_owned(),
            _ => PathBuf::from("."),
        };
        // A dangling symlink: the file it will make is its target's.
        if let Ok(target) = std::fs::read_link(&path) {
            path = folder.join(target);
            continue;
        }
        let name = path
            .file_name()
            .ok_or_else(|| io::Error::other("the path does not name a file"))?;
        return Ok(FileKey::Planned(std::fs::canonicalize(folder)?.join(name)));
    }
    Err(io::Error::other("too many levels of symbolic links"))
}

#[cfg(unix)]
fn inode(_path: &Path, metadata: &std::fs::Metadata) -> FileKey {
    use std::os::unix::fs::MetadataExt;
    FileKey::Inode(metadata.dev(), metadata.ino())
}

#[cfg(not(unix))]
fn inode(path: &Path, _metadata: &std::fs::Metadata) -> FileKey {
    FileKey::Planned(std::fs::canonicalize(path).unwrap_or_else(|_| path.to_owned()))
}

/// The first pair of `uses` that name one file where at least one of the two is
/// written. Paths that cannot be resolved (a missing folder) are left to the
/// checks that report them.
pub fn collision<L: Clone>(uses: &[PathUse<L>]) -> Option<Collision<L>> {
    let keys: Vec<Option<FileKey>> = uses.iter().map(|u| key(&u.path).ok()).collect();
    for (i, a) in uses.iter().enumerate() {
        for (j, b) in uses.iter().enumerate().skip(i + 1) {
            if a.role == Role::Input && b.role == Role::Input {
                continue;
            }
            if keys[i].is_some() && keys[i] == keys[j] {
                return Some(Collision {
                    first: a.clone(),
                    second: b.clone(),
                });
            }
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_same_file_is_found_however_it_is_named() {
        let temp = tempfile::Builder::new()
            .prefix("pathmix-paths-same-")
            .tempdir()
            .unwrap();
        let dir = temp.path();
        let file = dir.join("a.exr");
        std::fs::write(&file, "x").unwrap();
        std::fs::hard_link(&file, dir.join("hard.exr")).unwrap();
        #[cfg(unix)]
        std::os::unix::fs::symlink(&file, dir.join("soft.exr")).unwrap();
        #[cfg(unix)]
        std::os::unix::fs::symlink(dir.join("later.exr"), dir.join("dangling.exr")).unwrap();
        std::fs::create_dir(dir.join("sub")).unwrap();
        let mut names = vec![
            dir.join("hard.exr"),
            dir.join("sub/../a.exr"),
            dir.join("./a.exr"),
        ];
        if cfg!(unix) {
            names.push(dir.join("soft.exr"));
        }
        for other in names {
            let uses = [
                PathUse::input("SCENE", &file),
                PathUse::output("--exr", &other),
            ];
            let message = collision(&uses)
                .unwrap_or_else(|| panic!("{}", other.display()))
                .to_string();
            assert!(
                message.contains("SCENE") && message.contains("--exr"),
                "{message}"
            );
        }
        // Files to be made: the same name in the same folder, or through a dangling link.
        let planned = [
            PathUse::output("-o", &dir.join("new.exr")),
            PathUse::output("--exr", &dir.join("sub/../new.exr")),
        ];
        assert!(collision(&planned).is_some());
        #[cfg(unix)]
        assert!(
            collision(&[
                PathUse::output("--exr", &dir.join("dangling.exr")),
                PathUse::output("--variance", &dir.join("later.exr")),
            ])
            .is_some()
        );
        // Distinct files, and two inputs of one file, are fine.
        assert!(
            collision(&[
                PathUse::output("-o", &dir.join("a.exr")),
                PathUse::output("--exr", &dir.join("b.exr")),
            ])
            .is_none()
        );
        assert!(
            collision(&[PathUse::input("PART", &file), PathUse::input("PART", &file)]).is_none()
        );
    }
}
