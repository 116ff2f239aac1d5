//! Valid modules that raykit's SPIR-V intake must accept (the other side of the
//! bad-input catalogue).

use raykit::{LinkOptions, Module, Pipeline, ProgramGroup, ProgramKind, Sbt};
use raykit_tests::with_context;

/// `glslangValidator -gVS` adds NonSemantic.Shader.DebugInfo.100 instructions,
/// which rspirv rejects outside functions: raykit used to refuse such modules as
/// "not a SPIR-V module". Reflection now leaves debug info out; the driver (and
/// the validation layer) still get the whole module.
#[test]
fn a_glsl_module_with_debug_info_loads_links_and_launches() -> anyhow::Result<()> {
    with_context("a_glsl_module_with_debug_info_loads_links_and_launches", |ctx| {
        let module = Module::new(ctx, include_bytes!("../data/raygen_debug_info.rgen.spv"))?;
        let kinds: Vec<_> = module.entry_points().iter().map(|e| (e.name.as_str(), e.kind)).collect();
        assert_eq!(kinds, [("main", Some(ProgramKind::Raygen))]);
        let raygen = ProgramGroup::raygen(&module, "main")?;
        let pipeline = Pipeline::<()>::new(ctx, &[&raygen], LinkOptions::default())?;
        let sbt = Sbt::builder(&pipeline).raygen(&raygen, ()).build()?;
        pipeline.launch(&sbt, &(), [4, 4, 1])?;
        Ok(())
    })
}
