// The patch mesh: every object refined into bilinear patches, in one world-space frame, with the
// receiving points (the unknowns) at patch corners.
#pragma once

#include "bounds.h"
#include "radiosity/scene.h"
#include "radiosity/settings.h"
#include "refine.h"
#include "transmission.h"

#include <array>
#include <vector>

namespace radiosity {

struct Patch {
  std::array<int, 4> vertex;  // corners in PatchMesh::vertices, counter-clockwise from the front
  std::array<int, 4> point;   // receiving point at each corner
  int material = 0;
  int object = 0;
  double area = 0.0;          // zero for degenerate patches: they neither shoot nor receive
  dvec3 normal{0.0};          // unit, front side
  dvec3 centre{0.0};
  double interior_share = 1.0;  // corner_view.h; 1 unless smooth-shaded
  // The patch this one is a coincident copy of (coincident_patches.h), or -1. A copy keeps zero area
  // and normal wherever it is placed: it takes no part in the lighting.
  int copy_of = -1;
};

// A receiving point. Corners meeting at a vertex share a point where their normals agree; a crease
// (floor meets wall) gives one point per side of it. Each point holds irradiance on both faces.
struct ReceiverPoint {
  dvec3 position;  // nudged slightly into its patches: a point exactly on a junction line sees the
                   // adjoining wall edge-on and would get nothing from it
  dvec3 normal;    // unit; zero when all its patches are degenerate
  // Per side: of the light reflected towards it from beyond its own patches, the part its corners
  // take (their mean). On a smooth-shaded surface Cycles' diffuse BSDF drops directions under the
  // corner's own facet, which the shading normal tilts away from (a Subdivision Surface's corners:
  // 1-2% at level 2; corner_view.h). 1 on flat patches.
  std::array<double, 2> reflected_share{1.0, 1.0};
  // Its object's, for the shots that may skip it (ObjectPatches::enclosed_side).
  int object = -1;
  int enclosed_side = -1;
  Sphere enclosure;
};

struct ObjectPatches {
  int patch_begin = 0, patch_end = 0;
  int point_begin = 0, point_end = 0;
  int vertex_begin = 0, vertex_end = 0;
  std::vector<int> face_levels;  // what it was refined with (face_levels): a moved object keeps its patches
  std::vector<QuadCell> cells;   // and the light's splits of those quads (split_cells); empty: none
  int degenerate = 0;     // zero-area patches
  // A closed surface (every edge of the input mesh shared by two faces, wound alike): the side of
  // its patches that faces its inside (0 front, 1 back), else -1.
  int closed_side = -1;
  // closed_side where no face lets light through, else -1; and a sphere round it. Nothing outside
  // the sphere lights that side, nor is lit from it: gathers skip those rays (gather.cpp; lamps
  // and sky, lights.cpp), which its own surface would block.
  int enclosed_side = -1;
  Sphere enclosure;
  bool mirrored = false;  // transform flips handedness
  std::vector<int> corner_slot;  // per input face corner: patch * 4 + corner at that place
  std::vector<int> patch_face;   // per patch (from patch_begin): the input face it came from
  // Some of its patches lie exactly on another object's, or another's on its (coincident_patches.h):
  // its corners read another object's light, or the other way round, so it cannot move or change
  // without a new patch mesh. Copies within the object move with it.
  bool coincident_with_others = false;
};

struct PatchMesh {
  dvec3 origin{0.0};     // world position of our frame's origin: the scene's centre, which keeps
                         // single-precision ray tracing exact enough far from the world origin
  double diagonal = 1.0; // scene size: ray offsets and relative sizes scale with it
  std::vector<dvec3> vertices;  // relative to origin
  std::vector<Patch> patches;
  std::vector<ReceiverPoint> points;
  std::vector<int> point_slot_begin;  // CSR: point -> patch * 4 + corner slots using it
  std::vector<int> point_slots;
  // Per slot (patch * 4 + corner), per side: the part of its point's view the patch fills at close
  // range, which the point takes at the corner's radiance (CornerView::own; 0 on flat surfaces).
  std::vector<std::array<double, 2>> own_view;
  std::vector<double> onward;  // per slot: CornerView::onward
  std::vector<dvec3> reflectance;  // per slot: the material's, or MeshDesc::corner_reflectance there
  std::vector<dvec3> emission;     // per slot: the material's, or MeshDesc::corner_emission there
  // Per slot: MeshDesc::corner_uv there as (u, v, 0), NaN on an object without; empty while none has.
  std::vector<dvec3> uv;
  // Per patch: what it lets through (transmission.h); empty while no patch lets light through.
  std::vector<Transmission> transmission;
  std::vector<ObjectPatches> objects;  // one per SceneDesc mesh
  int degenerate_patches = 0;

  bool emits(int patch) const {
    for (int c = 0; c < 4; ++c)
      if (emission[4 * patch + c] != dvec3(0.0)) return true;
    return false;
  }
};

// `cells`: per mesh, the light's splits of its quads (ObjectPatches::cells); empty: none anywhere.
PatchMesh build_patch_mesh(const SceneDesc& scene, const Settings& settings,
                           const std::vector<std::vector<QuadCell>>& cells = {});
// Widens [lo, hi] to the object's vertices.
void widen_to(const PatchMesh& pm, const ObjectPatches& obj, dvec3& lo, dvec3& hi);
// Refuses (std::invalid_argument, naming the largest) `meshes` that would take `pm` past
// Settings::max_patches; build_patch_mesh checks the whole scene before it refines anything.
void check_patch_budget(const PatchMesh& pm, const std::vector<MeshDesc>& meshes, const Settings& settings);
// Appends one more object (the next index), in the frame and at the sizes `pm` was built with.
void add_object(PatchMesh& pm, const MeshDesc& mesh, const std::vector<Material>& materials,
                const Settings& settings, std::vector<QuadCell> cells = {});

// The object's Transmission, closed_side and enclosed_side from its patches' materials (as added,
// or after a material's lobes change).
void take_optics(PatchMesh& pm, int object, const std::vector<Material>& materials);

// A patch's area and unit normal from its corners (half the cross product of its diagonals: exact
// for a planar quad); both zero where it is degenerate.
struct Facet {
  double area = 0.0;
  dvec3 normal{0.0};
};

// An object refined and where its transform puts it, worked out once for checking and placing.
struct PlacedObject {
  RefinedMesh refined;
  std::vector<dvec3> at;       // its vertices, in the patch mesh's frame
  std::vector<Facet> facets;   // per patch
  std::vector<dvec3> normals;  // per patch corner (4 a patch): the facet's, or on a smooth face the shading normal
};

// Moving or deforming one object in place, in two steps so a bad change is refused before anything
// changes: `mesh` (new transform or positions) must refine to the same patches as before, and keep
// the corners each receiving point holds facing one way, else std::invalid_argument; then the
// object's vertices, patches and points take the new places (their indices stay).
PlacedObject refine_object(const PatchMesh& pm, int object, const MeshDesc& mesh);
void place_object(PatchMesh& pm, int object, const MeshDesc& mesh, const PlacedObject& placed);

}  // namespace radiosity
