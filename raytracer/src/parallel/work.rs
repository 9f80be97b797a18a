//! The kinds of work the renderer charges to the framework's statistics
//! ([`hybrid_sched::Ctx::charge`]) and the simulator prices
//! ([`super::cost`]): one enum, so a misspelt kind does not compile.

hybrid_sched::work_kinds! {
    /// Every kind of work the renderer charges, by its name in the
    /// statistics and the cost model.
    pub enum Work {
        ClipNodes = "clip.nodes",
        ClipMisses = "clip.misses",
        /// Shadow bundles that reused a cell's selection (option `clip_cache`).
        ClipReused = "clip.reused",
        /// Of those, bundles whose whole selection was local already: nothing
        /// to select or pin (option `clip_cache`).
        ClipAllLocal = "clip.all_local",
        RaysPrimary = "rays.primary",
        RaysReflection = "rays.reflection",
        RaysRefraction = "rays.refraction",
        RaysPassThrough = "rays.pass_through",
        RaysAmbient = "rays.ambient",
        RaysSpawned = "rays.spawned",
        RaysRetired = "rays.retired",
        ShadowBundles = "shadow.bundles",
        ShadowBundlesDp = "shadow.bundles_dp",
        /// Bundles started in the step that shaded their point: every
        /// data-parallel one, and demand-driven ones whose cells are all
        /// resident, or (a processor with its own hierarchy) that needed no
        /// cell from elsewhere (option `inline_local_shadows`).
        ShadowBundlesInline = "shadow.bundles_inline",
        /// Demand-driven bundles tried in the step that shaded their point
        /// (a processor with its own hierarchy) that needed a cell held
        /// elsewhere, and were scheduled as usual.
        ShadowTriedElsewhere = "shadow.tried_elsewhere",
        /// Data-parallel bundles started where their point was shaded that
        /// stopped at a cell held elsewhere and joined the point's
        /// demand-driven task (option `inline_local_shadows`).
        ShadowJoined = "shadow.joined",
        ShadowSpawned = "shadow.spawned",
        ShadowRetired = "shadow.retired",
        ShadowPatches = "shadow.patches",
        ShadowTested = "shadow.tested",
        ShadowEstimated = "shadow.estimated",
        ShadowUnoccluded = "shadow.unoccluded",
        ShadowSegments = "shadow.transparent_segments",
        ShadowRestarts = "shadow.restarts",
        /// Non-empty octree leaves entered by traversals (octree steps).
        TraceLeaves = "trace.leaves",
        /// Objects listed in those leaves (intersection tests, counting an
        /// object once per leaf; an any-hit query may stop earlier).
        TraceObjects = "trace.objects",
        /// Queries answered by the processor's own hierarchy (option
        /// `local_kernel`): no leaves walked.
        TraceLocal = "trace.local",
        Shade = "shade",
        /// With an irradiance cache: lookups decided at pixels' owners.
        AmbientLookups = "ambient.lookups",
        /// Leak tests run (Radiance's `plugaleak`), where they ran.
        LeakTests = "ambient.leak_tests",
        /// Lookups whose leak tests left the pixel's owner as a task.
        LeakJobs = "ambient.leak_jobs",
    }
}
