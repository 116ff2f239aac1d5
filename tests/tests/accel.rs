//! Geometry input is validated before the GPU sees it.

use raykit::glam::Vec3;
use raykit::{Error, Gas};
use raykit_tests::with_context;

#[test]
fn bad_geometry_is_refused_with_the_reason() -> anyhow::Result<()> {
    with_context("bad_geometry_is_refused_with_the_reason", |ctx| {
        let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
        assert!(matches!(Gas::triangles(ctx, &[], None), Err(Error::Geometry(_))));
        let err = Gas::triangles(ctx, &[Vec3::ZERO, Vec3::X, Vec3::new(f32::NAN, 0.0, 0.0)], None).err();
        assert!(matches!(&err, Some(Error::Geometry(m)) if m.contains("vertex 2")), "{err:?}");
        let err = Gas::triangles(ctx, &tri, Some(&[0, 1, 3])).err();
        assert!(matches!(&err, Some(Error::Geometry(m)) if m.contains("out of range")), "{err:?}");
        let err = Gas::triangles(ctx, &tri, Some(&[0, 1])).err();
        assert!(matches!(&err, Some(Error::Geometry(m)) if m.contains("multiple of 3")), "{err:?}");
        assert!(matches!(Gas::triangles(ctx, &tri[..2], None), Err(Error::Geometry(_))));
        // Valid input still builds, indexed and not.
        Gas::triangles(ctx, &tri, None)?;
        Gas::triangles(ctx, &tri, Some(&[0, 1, 2]))?;
        Ok(())
    })
}
