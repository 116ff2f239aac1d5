//! The book in `docs/book/src/`, compiled: each chapter is a module whose
//! doctests are the chapter's Rust blocks, so `cargo test --doc -p raykit-book`
//! (part of `cargo xtask lint`) compiles every one against the workspace's
//! crates, and runs those that are not `no_run` (most run on the CPU backend,
//! which needs no Vulkan driver). `mdbook build docs/book` renders the same files.

macro_rules! chapters {
    ($($module:ident => $file:literal),* $(,)?) => {
        $(
            #[cfg(doctest)]
            #[doc = include_str!(concat!("src/", $file))]
            mod $module {}
        )*
    };
}

chapters! {
    introduction => "introduction.md",
    getting_started => "getting-started.md",
    own_project => "own-project.md",
    first_renderer => "first-renderer.md",
    next_week => "next-week.md",
    program_model => "program-model.md",
    launch_params => "launch-params.md",
    acceleration_structures => "acceleration-structures.md",
    runtime => "runtime.md",
    textures_and_scenes => "textures-and-scenes.md",
    cpu_backend => "cpu-backend.md",
    wgsl_and_glsl => "wgsl-and-glsl.md",
    viewer => "viewer.md",
    several_devices => "several-devices.md",
    checks => "checks.md",
    performance => "performance.md",
    porting => "porting.md",
    architecture => "architecture.md",
}
