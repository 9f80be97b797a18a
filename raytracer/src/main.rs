// The renderer's processors allocate small task and message buffers on
// several threads at once; glibc's allocator serialised them on an arena
// lock (futex wake-ups in the profile). mimalloc keeps per-thread heaps.
#[global_allocator]
static GLOBAL: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// mimalloc's option numbers (`mi_option_t` in `mimalloc.h`; retired
/// options keep their slots, so the numbers hold across versions).
const MI_OPTION_ARENA_EAGER_COMMIT: std::ffi::c_int = 4;
const MI_OPTION_PURGE_DELAY: std::ffi::c_int = 15;

extern "C" {
    fn mi_option_set(option: std::ffi::c_int, value: std::ffi::c_long);
}

fn main() {
    // Memory is committed as it is touched and returned as soon as it is
    // freed (by default mimalloc commits arenas eagerly and keeps freed
    // memory for a second), and no transparent huge pages (the `no_thp`
    // feature in Cargo.toml). Peak resident set, studio at 512x512:
    // sequential 46.7 MiB before, 19.2 MiB after; two processors with the
    // octree distribution 102 to 112 MiB before, 45 to 47 MiB after; the
    // same times.
    // SAFETY: plain setters of mimalloc's global options, called before
    // any other thread exists.
    unsafe {
        mi_option_set(MI_OPTION_ARENA_EAGER_COMMIT, 0);
        mi_option_set(MI_OPTION_PURGE_DELAY, 0);
    }
    std::process::exit(hybrid_rt::cli::main());
}
