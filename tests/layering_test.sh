#!/usr/bin/env bash
# Dependencies point down (docs/architecture.md): the layers below the simulator never include
# MuJoCo or sim/, planning never includes MuJoCo, and no header of ours pulls in MuJoCo, OMPL, FCL
# or OpenCV (they stay in the .cc files of the layer that needs them).
set -u
cd "$(dirname "$0")/../src"
fail=0
for layer in core robot kinematics planning grasp perception; do
  hits=$(grep -nE '#include [<"](mujoco/|sim/|render/|task/|bt/|campaign/|bench/|cli/)' "$layer"/*.h "$layer"/*.cc 2>/dev/null)
  if [ -n "$hits" ]; then echo "layer $layer includes a layer above it or MuJoCo:"; echo "$hits"; fail=1; fi
done
hits=$(grep -nE '#include [<"](bt/|faults/|campaign/|cli/|mujoco/)' task/*.h task/*.cc sim/*.h 2>/dev/null | grep -v '^sim/sim_world_impl.h:')
if [ -n "$hits" ]; then echo "task/ includes the behavior-tree layer, faults/, campaign/, cli/ or MuJoCo:"; echo "$hits"; fail=1; fi
# Fault injection reaches the task through its hooks and the hardware it wraps: never the tree or MuJoCo.
hits=$(grep -nE '#include [<"](bt/|campaign/|cli/|mujoco/)' faults/*.h faults/*.cc 2>/dev/null)
if [ -n "$hits" ]; then echo "faults/ includes the behavior-tree layer, campaign/, cli/ or MuJoCo:"; echo "$hits"; fail=1; fi
# The renderer sits beside the simulator: it reads the world and writes images, it runs no task.
hits=$(grep -nE '#include [<"](task/|bt/|faults/|campaign/|cli/|perception/|planning/)' render/*.h render/*.cc 2>/dev/null)
if [ -n "$hits" ]; then echo "render/ includes a layer above it:"; echo "$hits"; fail=1; fi
hits=$(grep -nE '#include [<"]render/' sim/*.h sim/*.cc task/*.h task/*.cc 2>/dev/null)
if [ -n "$hits" ]; then echo "sim/ or task/ includes render/:"; echo "$hits"; fail=1; fi
for layer in core robot sim render kinematics planning grasp perception task bt faults; do
  hits=$(grep -nE '#include [<"](campaign/|bench/|cli/)' "$layer"/*.h "$layer"/*.cc 2>/dev/null)
  if [ -n "$hits" ]; then echo "layer $layer includes campaign/, bench/ or cli/:"; echo "$hits"; fail=1; fi
done
# The standalone programs (bench/) stand beside campaign/ and share its experiment loading; the
# campaign never includes them.
hits=$(grep -nE '#include [<"](bench/|cli/)' campaign/*.h campaign/*.cc 2>/dev/null)
if [ -n "$hits" ]; then echo "campaign/ includes bench/ or cli/:"; echo "$hits"; fail=1; fi
hits=$(grep -nE '#include [<"]cli/' bench/*.h bench/*.cc 2>/dev/null)
if [ -n "$hits" ]; then echo "bench/ includes cli/:"; echo "$hits"; fail=1; fi
# The task layer's own helpers stay its own.
hits=$(grep -lE '#include [<"]task/plan_steps.h' */*.h */*.cc | grep -v '^task/')
if [ -n "$hits" ]; then echo "task/plan_steps.h is internal to task/, included by:"; echo "$hits"; fail=1; fi
# sim/sim_world_impl.h is SimWorld's insides, shared by its own source files only: the one header
# that may include MuJoCo, as long as nothing outside sim/ includes it.
hits=$(grep -nE '#include <(mujoco/|ompl/|fcl/|opencv|pcl/)' */*.h | grep -v '^sim/sim_world_impl.h:')
if [ -n "$hits" ]; then echo "heavy headers in our headers:"; echo "$hits"; fail=1; fi
# PCL's headers cost seconds of compile each: one file includes them.
hits=$(grep -lE '#include <pcl/' */*.h */*.cc | grep -v '^perception/segmentation.cc$')
if [ -n "$hits" ]; then echo "PCL included outside perception/segmentation.cc:"; echo "$hits"; fail=1; fi
hits=$(grep -lE '#include [<"]sim/sim_world_impl.h' */*.h */*.cc | grep -v '^sim/')
if [ -n "$hits" ]; then echo "sim/sim_world_impl.h is internal to sim/, included by:"; echo "$hits"; fail=1; fi
[ $fail -eq 0 ] && echo "layering ok"
exit $fail
