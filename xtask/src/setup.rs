//! Installing what raykit needs on a fresh machine: the pinned nightly for
//! rust-gpu, a Vulkan driver with ray tracing (Mesa ≥ 25 lavapipe on Debian
//! bookworm, from bookworm-backports), and the validation layers for tests.
//! Everything installed is announced; what cannot be installed is explained with
//! the exact commands to run.

use std::ffi::CStr;
use std::path::Path;
use std::process::Command;

use anyhow::{bail, Context as _};

fn output(cmd: &mut Command) -> Option<String> {
    let out = cmd.output().ok()?;
    out.status.success().then(|| String::from_utf8_lossy(&out.stdout).into_owned())
}

/// Installs the pinned nightly and its components when missing (through raykit-builder).
pub fn ensure_toolchain() -> anyhow::Result<()> {
    Ok(raykit_builder::ensure_toolchain(raykit_builder::Report::Terminal)?)
}

/// What the Vulkan probe found.
struct Probe {
    loader: bool,
    devices: Vec<(String, bool)>,
    validation_layer: bool,
}

impl Probe {
    fn has_ray_tracing(&self) -> bool {
        self.devices.iter().any(|(_, rt)| *rt)
    }
}

fn probe() -> Probe {
    // SAFETY: loads the system Vulkan loader, as any Vulkan program does.
    let Ok(entry) = (unsafe { ash::Entry::load() }) else {
        return Probe { loader: false, devices: Vec::new(), validation_layer: false };
    };
    // SAFETY: plain enumeration.
    let validation_layer = unsafe { entry.enumerate_instance_layer_properties() }.is_ok_and(|layers| {
        layers.iter().any(|l| l.layer_name_as_c_str().is_ok_and(|n| n == c"VK_LAYER_KHRONOS_validation"))
    });
    let app = ash::vk::ApplicationInfo::default().api_version(ash::vk::API_VERSION_1_2);
    let info = ash::vk::InstanceCreateInfo::default().application_info(&app);
    // SAFETY: valid create info; the instance is destroyed below.
    let Ok(instance) = (unsafe { entry.create_instance(&info, None) }) else {
        return Probe { loader: true, devices: Vec::new(), validation_layer };
    };
    let mut devices = Vec::new();
    // SAFETY: queries on a live instance, destroyed at the end.
    unsafe {
        for physical in instance.enumerate_physical_devices().unwrap_or_default() {
            let props = instance.get_physical_device_properties(physical);
            let name = props.device_name_as_c_str().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
            let rt_name: &CStr = ash::khr::ray_tracing_pipeline::NAME;
            let rt = instance
                .enumerate_device_extension_properties(physical)
                .unwrap_or_default()
                .iter()
                .any(|e| e.extension_name_as_c_str().is_ok_and(|n| n == rt_name));
            devices.push((name, rt));
        }
        instance.destroy_instance(None);
    }
    Probe { loader: true, devices, validation_layer }
}

pub fn is_root() -> bool {
    output(Command::new("id").arg("-u")).is_some_and(|s| s.trim() == "0")
}

fn debian_codename() -> Option<String> {
    let text = std::fs::read_to_string("/etc/os-release").ok()?;
    text.lines().find_map(|l| l.strip_prefix("VERSION_CODENAME=")).map(|s| s.trim_matches('"').to_owned())
}

const BACKPORTS_LIST: &str = "/etc/apt/sources.list.d/raykit-bookworm-backports.sources";

fn backports_configured() -> bool {
    let mut texts = Vec::new();
    if let Ok(t) = std::fs::read_to_string("/etc/apt/sources.list") {
        texts.push(t);
    }
    if let Ok(dir) = std::fs::read_dir("/etc/apt/sources.list.d") {
        for entry in dir.flatten() {
            if let Ok(t) = std::fs::read_to_string(entry.path()) {
                texts.push(t);
            }
        }
    }
    texts.iter().any(|t| t.contains("bookworm-backports"))
}

pub fn apt_get(args: &[&str]) -> anyhow::Result<()> {
    let mut cmd = Command::new("apt-get");
    cmd.args(args).env("DEBIAN_FRONTEND", "noninteractive");
    crate::run(&mut cmd, &format!("apt-get {}", args.join(" ")))
}

fn manual_driver_help() -> String {
    format!(
        "On Debian bookworm, as root:\n  \
         printf 'Types: deb\\nURIs: http://deb.debian.org/debian\\nSuites: bookworm-backports\\nComponents: main\\nSigned-By: /usr/share/keyrings/debian-archive-keyring.gpg\\n' > {BACKPORTS_LIST}\n  \
         apt-get update\n  \
         apt-get install -y -t bookworm-backports mesa-vulkan-drivers libvulkan1\n\
         Elsewhere: install a Vulkan driver with VK_KHR_ray_tracing_pipeline (Mesa ≥ 25 lavapipe, or a GPU driver)."
    )
}

/// Makes sure a Vulkan device with ray-tracing pipelines exists (installing
/// lavapipe when it can), and, for tests, the Khronos validation layer.
pub fn ensure_vulkan(validation: bool) -> anyhow::Result<()> {
    let mut found = probe();
    if !found.loader || !found.has_ray_tracing() {
        let seen = if found.devices.is_empty() {
            "no Vulkan devices".to_owned()
        } else {
            found.devices.iter().map(|(n, _)| n.as_str()).collect::<Vec<_>>().join(", ")
        };
        let apt = Path::new("/usr/bin/apt-get").exists();
        let bookworm = debian_codename().as_deref() == Some("bookworm");
        if !(is_root() && apt && bookworm) {
            bail!(
                "no Vulkan device with ray-tracing pipelines (seen: {seen}), and this machine is not Debian bookworm \
                 with root and apt, so xtask cannot install one.\n{}",
                manual_driver_help()
            );
        }
        println!("xtask: no Vulkan device with ray tracing (seen: {seen}); installing Mesa's lavapipe from bookworm-backports");
        if !backports_configured() {
            println!("xtask: adding bookworm-backports to apt's sources ({BACKPORTS_LIST})");
            std::fs::write(
                BACKPORTS_LIST,
                "Types: deb\nURIs: http://deb.debian.org/debian\nSuites: bookworm-backports\nComponents: main\n\
                 Signed-By: /usr/share/keyrings/debian-archive-keyring.gpg\n",
            )
            .with_context(|| format!("writing {BACKPORTS_LIST}"))?;
        }
        apt_get(&["update"])?;
        apt_get(&["install", "-y", "-t", "bookworm-backports", "mesa-vulkan-drivers", "libvulkan1"])?;
        found = probe();
        if !found.has_ray_tracing() {
            bail!("installed mesa-vulkan-drivers from bookworm-backports, but still no device with VK_KHR_ray_tracing_pipeline");
        }
        println!("xtask: lavapipe installed");
    }
    if validation && !found.validation_layer {
        if is_root() && Path::new("/usr/bin/apt-get").exists() {
            println!("xtask: installing the Vulkan validation layers (vulkan-validationlayers) for the tests");
            if apt_get(&["install", "-y", "vulkan-validationlayers"]).is_err() {
                apt_get(&["update"])?;
                apt_get(&["install", "-y", "vulkan-validationlayers"])?;
            }
        } else {
            bail!(
                "the tests run with the Khronos validation layer, which is not installed. \
                 On Debian, as root: apt-get install -y vulkan-validationlayers"
            );
        }
    }
    Ok(())
}

/// The tools that rebuild the committed SPIR-V (`glslangValidator`, SPIRV-Tools),
/// and the Debian packages that have them.
const GLSL_TOOLS: [&str; 4] = ["glslangValidator", "spirv-opt", "spirv-val", "spirv-as"];
const GLSL_PACKAGES: [&str; 2] = ["glslang-tools", "spirv-tools"];

/// Makes sure glslang and the SPIRV-Tools are installed (installing them as root
/// with apt), so the tests can rebuild the committed SPIR-V and compare it.
pub fn ensure_glsl_tools() -> anyhow::Result<()> {
    ensure_tools(&GLSL_TOOLS, &GLSL_PACKAGES, "the tests rebuild the committed SPIR-V")
}

/// Embree 3's library, which the bench's `cpu` suite loads for its twin, and
/// the Debian package that has it.
const EMBREE_LIBRARY: &str = "/usr/lib/x86_64-linux-gnu/libembree3.so.3";
const EMBREE_PACKAGES: [&str; 1] = ["libembree3-3"];

/// Makes sure Embree 3 is installed (installing it as root with apt), for the
/// `cpu` suite's Embree rows.
pub fn ensure_embree() -> anyhow::Result<()> {
    let present = |path: &str| Path::new(path).is_file();
    ensure_present(&[EMBREE_LIBRARY], present, &EMBREE_PACKAGES, "the cpu suite measures the CPU backend against it")
}

/// Makes sure the SPIRV-Tools that rust-gpu's codegen backend runs
/// ([`raykit_builder::SPIRV_TOOLS`]) are installed, installing them as root with apt.
pub fn ensure_spirv_tools() -> anyhow::Result<()> {
    ensure_tools(&raykit_builder::SPIRV_TOOLS, &["spirv-tools"], "rust-gpu's codegen backend runs them")
}

/// Makes sure every one of `tools` runs, installing `packages` as root with apt
/// when one does not; `why` says what needs them.
fn ensure_tools(tools: &[&str], packages: &[&str], why: &str) -> anyhow::Result<()> {
    ensure_present(tools, |t| output(Command::new(t).arg("--version")).is_some(), packages, why)
}

/// Makes sure every one of `commands` is on `PATH`, installing `packages` as
/// root with apt when one is not; `why` says what needs them.
pub fn ensure_commands(commands: &[&str], packages: &[&str], why: &str) -> anyhow::Result<()> {
    let on_path = |c: &str| {
        std::env::var_os("PATH").is_some_and(|path| std::env::split_paths(&path).any(|dir| dir.join(c).is_file()))
    };
    ensure_present(commands, on_path, packages, why)
}

/// Makes sure `present` holds for every one of `names`, installing `packages`
/// as root with apt when it does not; `why` says what needs them.
fn ensure_present(names: &[&str], present: impl Fn(&str) -> bool, packages: &[&str], why: &str) -> anyhow::Result<()> {
    let missing = || -> Vec<&str> { names.iter().copied().filter(|n| !present(n)).collect() };
    let absent = missing();
    if absent.is_empty() {
        return Ok(());
    }
    if !(is_root() && Path::new("/usr/bin/apt-get").exists()) {
        bail!(
            "{} not installed ({why}). On Debian, as root: apt-get install -y {}",
            absent.join(", "),
            packages.join(" ")
        );
    }
    println!("xtask: installing {} ({why})", packages.join(" "));
    let mut install = vec!["install", "-y"];
    install.extend(packages);
    if apt_get(&install).is_err() {
        apt_get(&["update"])?;
        apt_get(&install)?;
    }
    let absent = missing();
    if !absent.is_empty() {
        bail!("installed {} but {} still missing", packages.join(" "), absent.join(", "));
    }
    Ok(())
}
