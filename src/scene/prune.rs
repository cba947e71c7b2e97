//! Only what a scene uses reaches the kernel: definitions no object refers to
//! (materials today, the only named definitions) are dropped before packing.

use super::Scene;

impl Scene {
    /// This scene without the materials no object uses, the objects' material
    /// indices renumbered, and how many were dropped. Rendering it gives the
    /// same image: the kernel only ever reads the materials of what a ray hits.
    pub fn without_unused_materials(&self) -> (Scene, usize) {
        let used = self.used_materials();
        let mut renumbered = vec![u32::MAX; self.materials.len()];
        let mut materials = Vec::new();
        for (index, material) in self.materials.iter().enumerate() {
            if used[index] {
                renumbered[index] = materials.len() as u32;
                materials.push(material.clone());
            }
        }
        let dropped = self.materials.len() - materials.len();
        let mut scene = Scene {
            materials,
            ..self.clone()
        };
        let group_shapes = (scene.instancing.groups.iter_mut()).flat_map(|g| g.shapes.iter_mut());
        for shape in scene.shapes.iter_mut().chain(group_shapes) {
            let material = shape.material_mut();
            *material = renumbered[*material as usize];
        }
        (scene, dropped)
    }

    /// Whether some object uses each material, by index, or a material used
    /// is made of it (`twosided`).
    pub fn used_materials(&self) -> Vec<bool> {
        let mut used = vec![false; self.materials.len()];
        let group_shapes = (self.instancing.groups.iter()).flat_map(|g| g.shapes.iter());
        let references = (self.shapes.iter().chain(group_shapes)).map(|shape| shape.material());
        let mut stack: Vec<usize> = references.map(|m| m as usize).collect();
        // And the materials those are made of (`Material::nested`).
        while let Some(material) = stack.pop() {
            if used[material] {
                continue;
            }
            used[material] = true;
            for name in &self.materials[material].nested {
                if let Some(inner) = self.materials.iter().position(|m| &m.name == name) {
                    stack.push(inner);
                }
            }
        }
        used
    }
}

#[cfg(test)]
mod tests {
    use crate::scene::{Scene, Shapes};

    #[test]
    fn unused_materials_are_dropped_and_the_rest_renumbered() {
        let text = r#"
            [camera]
            lookfrom = [0, 0, 5]
            lookat = [0, 0, 0]
            [materials.unused_a]
            type = "lambertian"
            albedo = [0.1, 0.1, 0.1]
            [materials.red]
            type = "lambertian"
            albedo = [0.9, 0.1, 0.1]
            [materials.unused_b]
            type = "light"
            emit = [4, 4, 4]
            [materials.glass]
            type = "dielectric"
            ior = 1.5
            [[objects]]
            type = "sphere"
            center = [0, 0, 0]
            radius = 1
            material = "glass"
            [[objects]]
            type = "quad"
            q = [0, 0, 0]
            u = [1, 0, 0]
            v = [0, 1, 0]
            material = "red"
        "#;
        let scene = Scene::parse(text, "t.toml").unwrap();
        assert_eq!(scene.materials.len(), 4);
        let (pruned, dropped) = scene.without_unused_materials();
        assert_eq!(dropped, 2);
        let name = |i: u32| pruned.materials[i as usize].name.as_str();
        assert_eq!(name(pruned.shapes.spheres[0].material), "glass");
        assert_eq!(name(pruned.shapes.quads[0].material), "red");
        assert_eq!(pruned.materials.len(), 2);
        // Nothing left to drop, and a scene without objects keeps no material.
        assert_eq!(pruned.without_unused_materials(), (pruned.clone(), 0));
        let empty = Scene {
            shapes: Shapes::default(),
            ..scene
        };
        let (none, dropped) = empty.without_unused_materials();
        assert!(none.materials.is_empty());
        assert_eq!(dropped, 4);
    }
}
