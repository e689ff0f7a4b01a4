// Preloaded into the MPI ranks of the MPI tests under AddressSanitizer (see CMakeLists.txt):
// dlclose does nothing, so Open MPI's components stay mapped until the process ends and
// LeakSanitizer can name the component that made each allocation Open MPI keeps past
// MPI_Finalize (openmpi_lsan.supp suppresses those by library). Test use only.
#include <cstdlib>

extern "C" int dlclose(void* /*handle*/) { return 0; }

namespace {
// The rank's children (the figure scripts) start without the preloaded libraries.
[[gnu::constructor]] void ForgetPreload() { unsetenv("LD_PRELOAD"); }
}  // namespace
