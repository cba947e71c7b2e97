//! The deployment files in deploy/: the Kubernetes manifests checked against the
//! fields a Job needs and run as local processes the way the Indexed Job runs
//! them, and the pathmix flags the shell scripts use checked against the CLI.
//! (The Slurm scripts run for real on a one-node cluster in
//! deploy/slurm/local-test.sh, which CI runs.)

mod common;

use common::pathmix;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use yaml_rust2::{Yaml, YamlLoader};

fn repo(path: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(path)
}

fn read(path: &str) -> String {
    std::fs::read_to_string(repo(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
}

fn text(bytes: &[u8]) -> String {
    String::from_utf8_lossy(bytes).into_owned()
}

/// Every document of a manifest file.
fn documents(path: &str) -> Vec<Yaml> {
    YamlLoader::load_from_str(&read(path)).unwrap_or_else(|e| panic!("{path}: {e}"))
}

/// The one document of `kind` named `name`.
fn find<'a>(docs: &'a [Yaml], kind: &str, name: &str) -> &'a Yaml {
    let found: Vec<_> = docs
        .iter()
        .filter(|d| {
            d["kind"].as_str() == Some(kind) && d["metadata"]["name"].as_str() == Some(name)
        })
        .collect();
    assert_eq!(found.len(), 1, "one {kind} named {name}");
    found[0]
}

fn str_at<'a>(node: &'a Yaml, what: &str) -> &'a str {
    node.as_str()
        .unwrap_or_else(|| panic!("{what}: expected a string, found {node:?}"))
}

/// A Job as Kubernetes' batch/v1 schema requires it (the fields pathmix's manifests
/// use): returns its one container.
fn check_job<'a>(job: &'a Yaml, name: &str) -> &'a Yaml {
    assert_eq!(job["apiVersion"].as_str(), Some("batch/v1"), "{name}");
    let pod = &job["spec"]["template"]["spec"];
    // A Job's pods must not be restarted in place by the kubelet with Always.
    let restart = str_at(&pod["restartPolicy"], "restartPolicy");
    assert!(
        ["Never", "OnFailure"].contains(&restart),
        "{name}: {restart}"
    );
    let containers = pod["containers"].as_vec().expect("containers");
    assert_eq!(containers.len(), 1, "{name}: one container");
    let container = &containers[0];
    str_at(&container["name"], "container name");
    str_at(&container["image"], "image");
    let command = container["command"].as_vec().expect("command: a list");
    assert!(!command.is_empty());
    for part in command {
        str_at(part, "command item");
    }
    // Env values must be strings (`value: 4` is refused by the API server).
    for var in container["env"].as_vec().expect("env") {
        str_at(&var["name"], "env name");
        str_at(&var["value"], &format!("env {:?} value", var["name"]));
    }
    // Every mount names a volume of the pod.
    let volumes: Vec<&str> = pod["volumes"]
        .as_vec()
        .expect("volumes")
        .iter()
        .map(|v| str_at(&v["name"], "volume name"))
        .collect();
    for mount in container["volumeMounts"].as_vec().expect("volumeMounts") {
        let volume = str_at(&mount["name"], "mount name");
        assert!(
            volumes.contains(&volume),
            "{name}: mount of unknown volume {volume}"
        );
        assert!(str_at(&mount["mountPath"], "mountPath").starts_with('/'));
    }
    container
}

fn env_of(container: &Yaml) -> BTreeMap<String, String> {
    container["env"]
        .as_vec()
        .unwrap()
        .iter()
        .map(|v| {
            (
                str_at(&v["name"], "").to_string(),
                str_at(&v["value"], "").to_string(),
            )
        })
        .collect()
}

fn command_of(container: &Yaml) -> Vec<String> {
    container["command"]
        .as_vec()
        .unwrap()
        .iter()
        .map(|c| str_at(c, "command").to_string())
        .collect()
}

fn volume<'a>(job: &'a Yaml, name: &str) -> &'a Yaml {
    job["spec"]["template"]["spec"]["volumes"]
        .as_vec()
        .unwrap()
        .iter()
        .find(|v| v["name"].as_str() == Some(name))
        .unwrap_or_else(|| panic!("no volume {name}"))
}

#[test]
fn kubernetes_manifests_are_an_indexed_render_job_and_a_merge_job() {
    let render_docs = documents("deploy/k8s/render-job.yaml");
    let merge_docs = documents("deploy/k8s/merge-job.yaml");

    let render = find(&render_docs, "Job", "pathmix-render");
    let container = check_job(render, "pathmix-render");
    let spec = &render["spec"];
    assert_eq!(spec["completionMode"].as_str(), Some("Indexed"));
    let completions = spec["completions"].as_i64().expect("completions");
    let parallelism = spec["parallelism"].as_i64().expect("parallelism");
    assert!(completions >= 1 && (1..=completions).contains(&parallelism));
    assert!(spec["backoffLimit"].as_i64().is_some_and(|b| b >= 0));
    let render_env = env_of(container);
    // The shard count the script is given is the Job's completion count.
    assert_eq!(render_env["SHARDS"], completions.to_string());
    // Each pod's index picks its shard.
    let command = command_of(container);
    assert_eq!(command[..2], ["sh", "-c"]);
    assert!(
        command[2].contains("render-shard.sh \"$JOB_COMPLETION_INDEX\" \"$SHARDS\""),
        "{}",
        command[2]
    );
    // Only settings that deploy/render-shard.sh reads.
    let documented = read("deploy/render-shard.sh");
    for name in render_env.keys() {
        assert!(
            name == "SHARDS" || documented.contains(&format!("#   {name} ")),
            "{name} is not a setting of deploy/render-shard.sh"
        );
    }
    // Parts go to a shared volume (every pod writes, the merge reads).
    let claim = str_at(
        &volume(render, "data")["persistentVolumeClaim"]["claimName"],
        "claimName",
    );
    let pvc = find(&render_docs, "PersistentVolumeClaim", claim);
    assert_eq!(pvc["apiVersion"].as_str(), Some("v1"));
    assert_eq!(
        pvc["spec"]["accessModes"][0].as_str(),
        Some("ReadWriteMany")
    );
    assert_eq!(
        volume(render, "config")["configMap"]["name"].as_str(),
        Some("pathmix")
    );

    let merge = find(&merge_docs, "Job", "pathmix-merge");
    let merge_container = check_job(merge, "pathmix-merge");
    assert!(
        merge["spec"]["completionMode"].is_badvalue(),
        "the merge is one pod"
    );
    let merge_env = env_of(merge_container);
    assert_eq!(merge_env["SHARDS"], completions.to_string(), "merge SHARDS");
    assert_eq!(
        merge_env["OUT"], render_env["OUT"],
        "the merge reads the parts' folder"
    );
    assert!(command_of(merge_container)[2].contains("merge.sh \"$SHARDS\""));
    assert_eq!(
        volume(merge, "data")["persistentVolumeClaim"]["claimName"].as_str(),
        Some(claim)
    );
    assert_eq!(container["image"], merge_container["image"]);
}

/// The `--flags` of the `pathmix SUBCOMMAND` statements of a shell script
/// (`"$PATHMIX" render ...`, `"${PATHMIX:-pathmix}" merge ...`).
fn script_flags(script: &str, subcommand: &str) -> Vec<String> {
    let joined = read(script).replace("\\\n", " ");
    let statements: Vec<&str> = joined
        .lines()
        .filter(|line| !line.trim_start().starts_with('#'))
        .filter(|line| {
            line.contains(&format!("PATHMIX\" {subcommand} "))
                || line.contains(&format!("pathmix}}\" {subcommand} "))
        })
        .collect();
    assert!(
        !statements.is_empty(),
        "{script}: no `pathmix {subcommand}` line"
    );
    let mut flags = Vec::new();
    for statement in statements {
        // `--name` anywhere, also inside `${SPP:+--spp "$SPP"}`.
        for (start, _) in statement.match_indices("--") {
            let before = statement[..start].chars().last();
            if before.is_some_and(|c| c.is_ascii_alphanumeric() || c == '-') {
                continue;
            }
            let name: String = statement[start + 2..]
                .chars()
                .take_while(|c| c.is_ascii_alphanumeric() || *c == '-')
                .collect();
            if name.starts_with(|c: char| c.is_ascii_lowercase()) {
                flags.push(format!("--{name}"));
            }
        }
    }
    flags
}

fn help(subcommand: &str) -> String {
    let output = pathmix(&[subcommand, "--help"]);
    assert!(output.status.success());
    text(&output.stdout)
}

fn assert_in_help(flags: &[String], help: &str, what: &str) {
    assert!(!flags.is_empty(), "{what}: no flags found");
    for flag in flags {
        let listed = help.lines().any(|line| {
            line.trim_start()
                .split([',', ' ', '='])
                .any(|word| word == flag)
        });
        assert!(listed, "{what} uses {flag}, which `pathmix` does not have");
    }
}

#[test]
fn deploy_scripts_use_flags_that_pathmix_has() {
    let render_help = help("render");
    let flags = script_flags("deploy/render-shard.sh", "render");
    for expected in [
        "--spp",
        "--shard",
        "--partial",
        "--checkpoint",
        "--checkpoint-every",
        "--resume",
    ] {
        assert!(
            flags.iter().any(|f| f == expected),
            "{expected} in {flags:?}"
        );
    }
    assert_in_help(&flags, &render_help, "deploy/render-shard.sh");
    let flags = script_flags("deploy/merge.sh", "merge");
    assert_eq!(flags, ["--exr"]);
    assert_in_help(&flags, &help("merge"), "deploy/merge.sh");
    // PATHMIX_FLAGS given in the manifests and the Slurm test are render flags too.
    let local_test = read("deploy/slurm/local-test.sh");
    assert!(local_test.contains("PATHMIX_FLAGS=\"--width $SIZE --height $SIZE\""));
    assert_in_help(
        &["--width".into(), "--height".into()],
        &render_help,
        "local-test.sh",
    );
    let assert_compare =
        |flag: &str| assert_in_help(&[flag.into()], &help("compare"), "local-test.sh");
    assert_compare("--tolerance");
    // A flag pathmix lacks is caught.
    let caught = std::panic::catch_unwind(|| {
        assert_in_help(&["--shards".into()], &render_help, "a typo");
    });
    assert!(caught.is_err());
}

/// The `--from-file` sources of the `kubectl create configmap` command in a
/// manifest's comment: (key, repository path).
fn configmap_files(manifest: &str) -> Vec<(String, String)> {
    read(manifest)
        .split("--from-file=")
        .skip(1)
        .map(|rest| {
            let source = rest.split([' ', '\n', '\\']).next().unwrap();
            match source.split_once('=') {
                Some((key, path)) => (key.to_string(), path.to_string()),
                None => (
                    Path::new(source)
                        .file_name()
                        .unwrap()
                        .to_str()
                        .unwrap()
                        .to_string(),
                    source.to_string(),
                ),
            }
        })
        .collect()
}

/// Runs a container's command here as a local process: its env from the manifest
/// (with `extra` on top), each volume's mount path replaced by a folder of `root`,
/// and pathmix's folder on PATH as in the image.
fn run_container(container: &Yaml, root: &Path, extra: &[(&str, String)]) -> Output {
    let mut mounts = Vec::new();
    for mount in container["volumeMounts"].as_vec().unwrap() {
        let name = str_at(&mount["name"], "");
        mounts.push((
            str_at(&mount["mountPath"], "").to_string(),
            root.join(name).display().to_string(),
        ));
    }
    let local = |s: &str| {
        let mut s = s.to_string();
        for (mount, dir) in &mounts {
            s = s.replace(&format!("{mount}/"), &format!("{dir}/"));
        }
        s
    };
    let command = command_of(container);
    let mut process = Command::new(&command[0]);
    process.args(command[1..].iter().map(|a| local(a)));
    for (name, value) in env_of(container) {
        process.env(name, local(&value));
    }
    let bin_dir = Path::new(env!("CARGO_BIN_EXE_pathmix")).parent().unwrap();
    let path = std::env::var("PATH").unwrap_or_default();
    process
        .env("PATH", format!("{}:{path}", bin_dir.display()))
        .env_remove("PATHMIX")
        .envs(extra.iter().map(|(k, v)| (k, v)))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    process.output().unwrap()
}

/// The manifests' commands as Kubernetes would run them, here as local processes:
/// one pod per completion index with its JOB_COMPLETION_INDEX, the config volume
/// holding the ConfigMap the manifest's comment creates, a shared data folder;
/// then the merge Job's pod; the merged image equals one run of the same samples.
#[cfg(unix)]
#[test]
fn kubernetes_pods_run_as_local_processes_merge_to_one_run() {
    if common::gpu().is_none() {
        return;
    }
    let root = common::TempDir::new("deploy", "k8s");
    let render_docs = documents("deploy/k8s/render-job.yaml");
    let render = find(&render_docs, "Job", "pathmix-render");
    let merge_docs = documents("deploy/k8s/merge-job.yaml");
    let merge = find(&merge_docs, "Job", "pathmix-merge");

    // The ConfigMap: the files the manifest's comment puts in it.
    let files = configmap_files("deploy/k8s/render-job.yaml");
    let keys: Vec<&str> = files.iter().map(|(k, _)| k.as_str()).collect();
    assert_eq!(keys, ["render-shard.sh", "merge.sh", "scene.toml"]);
    std::fs::create_dir_all(root.join("config")).unwrap();
    std::fs::create_dir_all(root.join("data")).unwrap();
    for (key, path) in &files {
        std::fs::copy(repo(path), root.join("config").join(key)).unwrap();
    }

    // Small: the manifests' SPP and the scene's size would take minutes here.
    let spp = 12;
    let small = [
        ("SPP", spp.to_string()),
        ("PATHMIX_FLAGS", "--width 16 --height 12".to_string()),
    ];
    let completions = render["spec"]["completions"].as_i64().unwrap();
    let container = &render["spec"]["template"]["spec"]["containers"][0];
    let pods: Vec<_> = (0..completions)
        .map(|index| {
            let container = container.clone();
            let root = root.to_path_buf();
            let mut env = small.to_vec();
            env.push(("JOB_COMPLETION_INDEX", index.to_string()));
            std::thread::spawn(move || run_container(&container, &root, &env))
        })
        .collect();
    for pod in pods {
        let output = pod.join().unwrap();
        assert!(output.status.success(), "{}", text(&output.stderr));
    }
    let merged = run_container(
        &merge["spec"]["template"]["spec"]["containers"][0],
        &root,
        &[],
    );
    assert!(merged.status.success(), "{}", text(&merged.stderr));
    assert!(
        text(&merged.stdout).contains(&format!(
            "merged {completions} parts: 16x12, samples 0..{spp} "
        )),
        "{}",
        text(&merged.stdout)
    );

    let one = root.join("one.exr");
    let scene = root.join("config/scene.toml");
    let output = pathmix(&[
        "render",
        scene.to_str().unwrap(),
        "--spp",
        &spp.to_string(),
        "--width",
        "16",
        "--height",
        "12",
        "--exr",
        one.to_str().unwrap(),
        // As the parts: their error estimate lays out Sobol's samples in replicates.
        "--variance",
        root.join("one-se.exr").to_str().unwrap(),
        "-o",
        root.join("one.png").to_str().unwrap(),
        "--quiet",
    ]);
    assert!(output.status.success(), "{}", text(&output.stderr));
    let final_exr = root.join("data/final.exr");
    let output = pathmix(&[
        "compare",
        final_exr.to_str().unwrap(),
        one.to_str().unwrap(),
        "--tolerance",
        "1e-6",
    ]);
    assert!(
        output.status.success(),
        "{}{}",
        text(&output.stdout),
        text(&output.stderr)
    );
}
