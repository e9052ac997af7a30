//! What the renderer derives from a [`Scene`]: the shared vertex and index arrays, the draw
//! ranges, the per-object push constants and matrices, and the scene's checks.

use super::*;

impl Scene {
    /// A scene whose objects are sorted nearest first (by the view depth of their centers),
    /// drawn in that order in one render pass with the standard pipeline: drawing front to
    /// back means the depth test, not the draw order, decides visibility.
    pub fn new(name: &'static str, camera: Camera, mut objects: Vec<Object>) -> Scene {
        let mut scene = Scene {
            name,
            camera,
            light: None,
            objects: Vec::new(),
            plan: Plan::single_pass(0),
        };
        objects.sort_by(|a, b| scene.view_depth(a).total_cmp(&scene.view_depth(b)));
        scene.plan = Plan::single_pass(objects.len());
        scene.objects = objects;
        scene
    }

    /// Distance of the object's center in front of the eye, along the view direction.
    pub fn view_depth(&self, object: &Object) -> f64 {
        (object.world_center() - self.camera.eye).dot(self.camera.forward())
    }

    /// P * V (f64).
    pub fn view_projection(&self, aspect: f64) -> DMat4 {
        self.camera.projection(aspect) * self.camera.view()
    }

    /// The object's camera MVP in f64: P * V * M (or M for a clip-space object).
    #[cfg(test)]
    pub fn mvp(&self, object: &Object, aspect: f64) -> DMat4 {
        self.mvp_in(View::Camera, object, aspect)
    }

    /// The object's complete clip transform for `view` in f64: what maps the positions in
    /// its vertex buffer ([`Scene::vertex_positions`]) to clip space: P * V * M for a world
    /// object, M for a clip-space one, P * V or P for baked ones. (A scene without a light
    /// uses its camera for [`View::Light`]; [`Plan::check`] keeps that from happening.)
    pub fn mvp_in(&self, view: View, object: &Object, aspect: f64) -> DMat4 {
        let view_projection = self.view_projection_in(view, aspect);
        match object.space {
            Space::Clip => object.model,
            Space::World => view_projection * object.model,
            Space::WorldBaked => view_projection,
            // The vertices are in the camera's view space: undo V first.
            Space::ViewBaked => match (view, &self.light) {
                (View::Light, Some(_)) => view_projection * self.camera.view().inverse(),
                _ => self.camera.projection(aspect),
            },
        }
    }

    /// The view-projection of `view`: the light's, or the camera's P * V.
    fn view_projection_in(&self, view: View, aspect: f64) -> DMat4 {
        match (view, &self.light) {
            (View::Light, Some(light)) => light.view_projection(),
            _ => self.view_projection(aspect),
        }
    }

    /// The positions in `object`'s vertex buffer, as f64 (exactly the f32 values the GPU
    /// gets): its mesh, or for baked objects the mesh transformed on the CPU in f64 and
    /// rounded once to f32.
    pub fn vertex_positions(&self, object: &Object) -> Vec<DVec3> {
        let bake = match object.space {
            Space::World | Space::Clip => return object.mesh.positions_f64().collect(),
            Space::WorldBaked => object.model,
            Space::ViewBaked => self.camera.view() * object.model,
        };
        object
            .mesh
            .positions_f64()
            .map(|p| bake.transform_point3(p).as_vec3().as_dvec3())
            .collect()
    }

    /// The push constants of `object` for `program` in the camera's view.
    #[cfg(test)]
    pub fn push_constants(&self, program: Program, object: &Object, aspect: f64) -> Vec<u8> {
        self.push_constants_in(program, View::Camera, object, aspect)
    }

    /// The scene with its matrices handed over by `delivery` ([`Plan::with_delivery`]); the
    /// error says why it cannot take it. `ubo-dynamic` also needs one view-projection for every
    /// object (one frame block): objects whose clip transform splits into another outer matrix
    /// than the others' ([`Scene::model_split`]: a full-screen quad beside world objects)
    /// cannot share it.
    pub fn with_delivery(&self, delivery: Delivery) -> Result<Scene, String> {
        let refuse = |why: String| {
            format!(
                "scene '{}' cannot take the {} delivery: {why}",
                self.name,
                delivery.name()
            )
        };
        let plan = self.plan.with_delivery(delivery).map_err(|e| refuse(e.0))?;
        if delivery == Delivery::UboDynamic {
            let outer = |o: &Object| self.model_split(View::Camera, o, 1.0).1;
            if let Some(first) = self.objects.first() {
                if let Some(other) = self.objects.iter().find(|o| outer(o) != outer(first)) {
                    return Err(refuse(format!(
                        "'{}' and '{}' need different view-projections, and its frame block \
                         holds one",
                        first.name, other.name
                    )));
                }
            }
        }
        Ok(Scene {
            plan,
            ..self.clone()
        })
    }

    /// The matrices the `ubo` delivery stores for `object` in the camera's view, each in f64,
    /// as (projection, view, model): (P, V, M) for a world object, (P, V, identity) when the
    /// model is baked into the vertices, (P, identity, identity) when the view is too, and
    /// (identity, identity, M) for a clip-space one. Their product is [`Scene::mvp_in`]'s.
    pub fn separate_matrices(&self, object: &Object, aspect: f64) -> [DMat4; 3] {
        let (p, v) = (self.camera.projection(aspect), self.camera.view());
        match object.space {
            Space::World => [p, v, object.model],
            Space::WorldBaked => [p, v, DMat4::IDENTITY],
            Space::ViewBaked => [p, DMat4::IDENTITY, DMat4::IDENTITY],
            Space::Clip => [DMat4::IDENTITY, DMat4::IDENTITY, object.model],
        }
    }

    /// `object`'s block in its buffer for a buffer-delivery `program`, in the camera's view,
    /// every value rounded once from f64 to f32 (std140 / std430 layouts, column-major):
    /// - [`Program::Ubo`]: P, V and M ([`Scene::separate_matrices`]) at 0, 64 and 128, the
    ///   color at 192 (208 bytes);
    /// - [`Program::UboDynamic`]: the model matrix ([`Scene::model_split`]'s inner one) at 0,
    ///   the color at 64 (80 bytes; the outer matrix is the frame block,
    ///   [`Scene::frame_block`]);
    /// - [`Program::Ssbo`]: the clip transform ([`Scene::mvp_in`]) at 0, the color at 64
    ///   (80 bytes); [`Program::SsboRows`] and [`Program::SsboRegisters`]: the same with the
    ///   matrix's rows at 0, 16, 32, 48;
    ///
    /// and nothing for the push-constant programs.
    pub fn object_block(&self, program: Program, object: &Object, aspect: f64) -> Vec<u8> {
        let matrices: Vec<DMat4> = match program.buffers().unwrap_or(program) {
            Program::Ubo => self.separate_matrices(object, aspect).to_vec(),
            Program::UboDynamic => vec![self.model_split(View::Camera, object, aspect).0],
            // The rows of the clip transform: its transpose, column-major.
            Program::Ssbo if matches!(program, Program::SsboRows | Program::SsboRegisters) => {
                vec![self.mvp_in(View::Camera, object, aspect).transpose()]
            }
            Program::Ssbo => vec![self.mvp_in(View::Camera, object, aspect)],
            _ => return Vec::new(),
        };
        let mut values: Vec<f32> = matrices
            .iter()
            .flat_map(|m| m.as_mat4().to_cols_array())
            .collect();
        values.extend(object.color);
        values.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    /// The frame block of [`Program::UboDynamic`]: the view-projection every object shares
    /// ([`Scene::model_split`]'s outer matrix: P * V for world objects), rounded once to f32
    /// (64 bytes, column-major); the camera's P * V for a scene without objects.
    pub fn frame_block(&self, aspect: f64) -> Vec<u8> {
        let view_proj = match self.objects.first() {
            Some(object) => self.model_split(View::Camera, object, aspect).1,
            None => self.view_projection(aspect),
        };
        view_proj
            .as_mat4()
            .to_cols_array()
            .iter()
            .flat_map(|v| v.to_le_bytes())
            .collect()
    }

    /// The push constants of `object` drawn with `program` in `view`, every value rounded once
    /// from f64 to f32 ([`Program::push_constant_size`] bytes):
    /// - [`Program::Flat`], [`Program::DepthOnly`], [`Program::FragDepth`],
    ///   [`Program::ShadowReceiver`], [`Program::LitMvp`]: the clip transform ([`Scene::mvp_in`]) column-major at
    ///   0, the RGBA color at 64;
    /// - [`Program::RowMajor`], [`Program::RowVector`]: the same transform row-major (its
    ///   transpose column-major) at 0, the color at 64;
    /// - [`Program::MvpPair`]: the model matrix (world objects; identity otherwise) at 0 and
    ///   the rest of the transform (P * V) at 64, both column-major;
    /// - the buffer deliveries ([`Program::Ubo`], [`Program::UboDynamic`], [`Program::Ssbo`]):
    ///   nothing (their matrices are in [`Scene::object_block`]).
    pub fn push_constants_in(
        &self,
        program: Program,
        view: View,
        object: &Object,
        aspect: f64,
    ) -> Vec<u8> {
        let mvp = self.mvp_in(view, object, aspect);
        let values: Vec<f32> = match program {
            Program::Flat
            | Program::DepthOnly
            | Program::FragDepth
            | Program::ShadowReceiver
            | Program::ShadowReceiverRaw
            | Program::LitMvp
            | Program::SplitPush
            | Program::FullPush
            | Program::ShaderObjects
            | Program::LinkedShaderObjects
            | Program::Mesh
            | Program::MeshShaderObjects
            | Program::PushGeometry
            | Program::SoftParticle
            | Program::DepthPost
            | Program::DepthTiles
            | Program::StencilPost
            | Program::DepthInput
            | Program::DepthInputUndecorated
            | Program::DepthMipsPost
            | Program::DepthLayersPost
            | Program::DepthPostMs => {
                let mut v = mvp.as_mat4().to_cols_array().to_vec();
                v.extend(object.color);
                v
            }
            // The view-projections are in the views' buffer ([`Scene::views_block`]).
            Program::Multiview => {
                let (model, _) = self.model_split(view, object, aspect);
                let mut v = model.as_mat4().to_cols_array().to_vec();
                v.extend(object.color);
                v
            }
            Program::RowMajor | Program::RowVector => {
                let mut v = mvp.as_mat4().transpose().to_cols_array().to_vec();
                v.extend(object.color);
                v
            }
            Program::MvpPair => {
                let (model, outer) = self.model_split(view, object, aspect);
                let mut v = model.as_mat4().to_cols_array().to_vec();
                v.extend(outer.as_mat4().to_cols_array());
                v
            }
            Program::Ubo
            | Program::UboDynamic
            | Program::Ssbo
            | Program::SsboRows
            | Program::SsboRegisters
            | Program::SsboColumns
            | Program::SsboVkd3d
            | Program::UboGeometry
            | Program::UboPassthroughGeometry
            | Program::UboTessellation
            | Program::UboInterpolatingTessellation
            | Program::UboProjectingTessellation
            | Program::UboTessellatedGeometry
            | Program::LinkedTessellationShaderObjects
            | Program::PassthroughGeometryShaderObjects
            | Program::ProjectingGeometryShaderObjects => Vec::new(),
        };
        debug_assert_eq!(values.len() * 4, program.push_constant_size() as usize);
        values.iter().flat_map(|v| v.to_le_bytes()).collect()
    }

    /// The clip transform split into (inner model matrix, outer matrix) as
    /// [`Program::MvpPair`] pushes it and [`Program::UboDynamic`] stores it: (M, P * V) for a
    /// world object, (identity, transform) otherwise.
    pub fn model_split(&self, view: View, object: &Object, aspect: f64) -> (DMat4, DMat4) {
        match object.space {
            Space::World => (object.model, self.view_projection_in(view, aspect)),
            _ => (DMat4::IDENTITY, self.mvp_in(view, object, aspect)),
        }
    }

    /// The matrices the GPU applies to `object`'s vertex positions for `program`, outermost
    /// first, in f64: `[P * V, M]` for [`Program::MvpPair`] and [`Program::UboDynamic`]
    /// (world objects), `[P, V, M]` for [`Program::Ubo`] ([`Scene::separate_matrices`]), the
    /// single clip transform otherwise.
    pub fn matrix_stages(
        &self,
        program: Program,
        view: View,
        object: &Object,
        aspect: f64,
    ) -> Vec<DMat4> {
        match (program.buffers().unwrap_or(program), object.space) {
            (Program::MvpPair | Program::UboDynamic | Program::Multiview, Space::World) => {
                let (model, outer) = self.model_split(view, object, aspect);
                vec![outer, model]
            }
            (Program::Ubo, _) if view == View::Camera => {
                self.separate_matrices(object, aspect).to_vec()
            }
            _ => vec![self.mvp_in(view, object, aspect)],
        }
    }

    /// The outermost matrix `program` pushes (or stores in its buffer) for `object` in the
    /// camera's view, as the shader applies it (`clip = M * v`, 16 f32 values column-major,
    /// whatever the storage order): the matrix a projection-rewriting layer sees. Its depth
    /// mapping (k, B) is that of the whole clip transform (an affine model or view matrix
    /// does not change it): P for [`Program::Ubo`], P * V for [`Program::MvpPair`] and
    /// [`Program::UboDynamic`], the whole clip transform otherwise.
    pub fn pushed_projection(&self, program: Program, object: &Object, aspect: f64) -> [f32; 16] {
        let outer = match program.buffers().unwrap_or(program) {
            Program::MvpPair | Program::UboDynamic | Program::Multiview => {
                self.model_split(View::Camera, object, aspect).1
            }
            Program::Ubo => self.separate_matrices(object, aspect)[0],
            _ => self.mvp_in(View::Camera, object, aspect),
        };
        outer.as_mat4().to_cols_array()
    }

    /// The cameras of a multiview pass's views, view 0 first: the scene's camera, and a second
    /// eye [`MULTIVIEW_EYE_SEPARATION`] to its right, looking the same way (its target moved
    /// with it: parallel eyes, as stereo renderers place them), with the same projection.
    pub fn view_cameras(&self) -> [Camera; 2] {
        let camera = &self.camera;
        let right = camera.forward().cross(camera.up).normalize() * MULTIVIEW_EYE_SEPARATION;
        let second = Camera {
            eye: camera.eye + right,
            target: camera.target + right,
            ..camera.clone()
        };
        [camera.clone(), second]
    }

    /// The scene seen from view `view` of a multiview pass ([`Scene::view_cameras`]; view 0
    /// is the scene itself): what that view's layer shows, for its ground truth.
    pub fn seen_from(&self, view: usize) -> Scene {
        Scene {
            camera: self.view_cameras()[view].clone(),
            ..self.clone()
        }
    }

    /// The uniform buffer [`Program::Multiview`] indexes with `gl_ViewIndex`: the P * V of each
    /// of [`Scene::view_cameras`] in f64, rounded once to f32, column-major (128 bytes).
    pub fn views_block(&self, aspect: f64) -> Vec<u8> {
        self.view_cameras()
            .iter()
            .flat_map(|camera| {
                (camera.projection(aspect) * camera.view())
                    .as_mat4()
                    .to_cols_array()
            })
            .flat_map(|v| v.to_le_bytes())
            .collect()
    }

    /// Every object's light MVP (f32, column-major), in object order: the uniform buffer
    /// `shadow_receiver.vert` indexes with the draw's firstInstance. Empty without a light.
    pub fn light_mvps(&self) -> Vec<[f32; 16]> {
        if self.light.is_none() {
            return Vec::new();
        }
        self.objects
            .iter()
            .map(|o| self.mvp_in(View::Light, o, 1.0).as_mat4().to_cols_array())
            .collect()
    }

    /// Packs every object's mesh into shared arrays, in draw order.
    pub fn geometry(&self) -> Geometry {
        let mut geometry = Geometry::default();
        for object in &self.objects {
            let range = DrawRange {
                first_index: u32::try_from(geometry.indices.len()).expect("too many indices"),
                index_count: u32::try_from(object.mesh.indices.len()).expect("too many indices"),
                vertex_offset: i32::try_from(geometry.positions.len()).expect("too many vertices"),
            };
            geometry.positions.extend(
                self.vertex_positions(object)
                    .iter()
                    .map(|p| p.as_vec3().to_array()),
            );
            geometry.indices.extend_from_slice(&object.mesh.indices);
            geometry.draws.push(range);
        }
        geometry
    }
}
