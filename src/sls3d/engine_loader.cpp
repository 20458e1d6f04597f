// Loads the finite-element engine (src/sls3d/fe/engine.cpp, a shared library linked against
// deal.II) on first use. Keeping it out of the amctl binary and the Python extension spares
// every other command the cost of loading deal.II and its ~200 libraries (docs/sls3d.md,
// "Build and loading"). Looked for, in order:
//   1. $AMCTL_SLS3D_ENGINE (a path to the library),
//   2. the library this build made (its absolute path, compiled in),
//   3. libamctl_sls3d_engine.so next to the binary that contains this code, or in ../lib.
#include <dlfcn.h>

#include <cstdlib>
#include <filesystem>
#include <mutex>
#include <string>
#include <vector>

#include "amctl/core/error.hpp"
#include "amctl/sls3d/plant.hpp"

namespace amctl::sls3d {
namespace {

constexpr int kOpenFlags = RTLD_NOW | RTLD_LOCAL;

// A library already in the process's global scope that defines MPI functions other than
// Open MPI's would take their place for deal.II and p4est (the sequential MUMPS that IPOPT
// links exports stub MPI_Init, MPI_Comm_rank, MPI_Finalize and MPI_Wtime: every rank would
// be rank 0). That is why `amctl thermal sls3d` runs in its own executable, amctl-sls3d,
// which does not link IPOPT. Returns the offending library, or "".
[[maybe_unused]] std::string shadowing_mpi_library() {
  for (const char* name : {"MPI_Init", "MPI_Comm_rank", "MPI_Finalize"}) {
    void* sym = dlsym(RTLD_DEFAULT, name);
    if (!sym) continue;
    Dl_info info{};
    if (dladdr(sym, &info) && info.dli_fname) {
      const std::string lib = std::filesystem::path(info.dli_fname).filename().string();
      if (lib.rfind("libmpi.", 0) != 0 && lib.rfind("libmpi_", 0) != 0) return info.dli_fname;
    }
  }
  return "";
}

struct Engine {
  MakePlantFn make = nullptr;
  std::string error;
};

const Engine& engine() {
  static Engine e;
  static std::once_flag once;
  std::call_once(once, [] {
#ifndef AMCTL_SLS3D_ENGINE_PATH
    e.error = "amctl was built without deal.II, so the 3D powder-bed model is not available "
              "(install libdeal.ii-dev, scripts/install-deps.sh, and rebuild)";
#else
    if (const std::string lib = shadowing_mpi_library(); !lib.empty()) {
      e.error = "the 3D powder-bed engine cannot run in this process: " + lib +
                " defines MPI functions that would replace Open MPI's (run it through amctl-sls3d "
                "or `amctl thermal sls3d`)";
      return;
    }
    std::vector<std::string> tried;
    if (const char* env = std::getenv("AMCTL_SLS3D_ENGINE"); env && *env) tried.push_back(env);
    tried.push_back(AMCTL_SLS3D_ENGINE_PATH);
    Dl_info info{};
    if (dladdr(reinterpret_cast<void*>(&engine_available), &info) && info.dli_fname) {
      const std::filesystem::path here = std::filesystem::path(info.dli_fname).parent_path();
      tried.push_back((here / "libamctl_sls3d_engine.so").string());
      tried.push_back((here / ".." / "lib" / "libamctl_sls3d_engine.so").string());
    }
    std::string why;
    for (const std::string& path : tried) {
      if (!std::filesystem::exists(path)) {
        why += "\n  " + path + ": not found";
        continue;
      }
      void* handle = dlopen(path.c_str(), kOpenFlags);
      if (!handle) {
        why += "\n  " + path + ": " + dlerror();
        continue;
      }
      // Kept open for the life of the process: MPI is finalised by its static destructors.
      if (void* sym = dlsym(handle, kEngineEntryPoint)) {
        e.make = reinterpret_cast<MakePlantFn>(sym);
        return;
      }
      why += "\n  " + path + ": no symbol " + kEngineEntryPoint;
    }
    e.error = "the 3D powder-bed engine (libamctl_sls3d_engine.so) could not be loaded; tried:" + why;
#endif
  });
  return e;
}

}  // namespace

int launcher_rank() {
  for (const char* name : {"OMPI_COMM_WORLD_RANK", "PMIX_RANK", "PMI_RANK"})
    if (const char* v = std::getenv(name); v && *v) return std::atoi(v);
  return 0;
}

bool engine_available(std::string* why) {
  const Engine& e = engine();
  if (why) *why = e.error;
  return e.make != nullptr;
}

std::unique_ptr<Plant> make_plant(const PlantSpec& spec) {
  const Engine& e = engine();
  if (!e.make) throw Error(e.error);
  std::unique_ptr<Plant> plant;
  e.make(spec, plant);
  return plant;
}

}  // namespace amctl::sls3d
