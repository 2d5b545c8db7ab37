// OpenSubdiv behind extern "C": Catmull–Clark refinement of a quad cage with
// Far::TopologyRefiner, and Far::StencilTable so that each new pose of the cage costs one
// weighted sum per refined vertex. Every exception becomes a tsk_status with a message.
#include "opensubdiv_bridge.h"

#include <cstring>
#include <exception>
#include <new>
#include <vector>

#include <opensubdiv/far/stencilTable.h>
#include <opensubdiv/far/stencilTableFactory.h>
#include <opensubdiv/far/topologyDescriptor.h>
#include <opensubdiv/far/topologyRefinerFactory.h>

using namespace OpenSubdiv;

// The float StencilTable(Factory) wrappers static_cast a StencilTableReal<float> to the
// derived StencilTable, which UBSan rightly reports; use the Real<float> types directly.
using Stencils = Far::StencilTableReal<float>;
using StencilFactory = Far::StencilTableFactoryReal<float>;

struct tsk_osd {
    const Stencils* stencils = nullptr;
    std::vector<int32_t> faces; // refined quads
    size_t cage_vertices = 0;
    size_t refined_vertices = 0;
    ~tsk_osd() { delete stencils; }
};

namespace {

struct apply_ctx {
    const Stencils* st;
    const float* cage;
    float* out;
};

void apply_range(size_t b, size_t e, size_t chunk, void* vctx) {
    (void)chunk;
    const apply_ctx* c = static_cast<const apply_ctx*>(vctx);
    const int* sizes = c->st->GetSizes().data();
    const Far::Index* offsets = c->st->GetOffsets().data();
    const Far::Index* idx = c->st->GetControlIndices().data();
    const float* w = c->st->GetWeights().data();
    for (size_t i = b; i < e; ++i) {
        const int n = sizes[i];
        const Far::Index o = offsets[i];
        float x = 0.0f, y = 0.0f, z = 0.0f;
        for (int k = 0; k < n; ++k) {
            const float* p = c->cage + 3 * static_cast<size_t>(idx[o + k]);
            const float wk = w[o + k];
            x += wk * p[0];
            y += wk * p[1];
            z += wk * p[2];
        }
        c->out[3 * i] = x;
        c->out[3 * i + 1] = y;
        c->out[3 * i + 2] = z;
    }
}

} // namespace

extern "C" tsk_status tsk_osd_create(const int32_t* quads, size_t face_count, size_t vertex_count,
                                     int levels, tsk_osd** out) {
    *out = nullptr;
    Far::TopologyRefiner* refiner = nullptr;
    try {
        std::vector<int> per_face(face_count, 4);
        std::vector<int> indices(quads, quads + 4 * face_count);
        Far::TopologyDescriptor desc;
        desc.numVertices = static_cast<int>(vertex_count);
        desc.numFaces = static_cast<int>(face_count);
        desc.numVertsPerFace = per_face.data();
        desc.vertIndicesPerFace = indices.data();
        Sdc::Options sdc;
        sdc.SetVtxBoundaryInterpolation(Sdc::Options::VTX_BOUNDARY_EDGE_ONLY);
        using Factory = Far::TopologyRefinerFactory<Far::TopologyDescriptor>;
        refiner = Factory::Create(desc, Factory::Options(Sdc::SCHEME_CATMARK, sdc));
        if (refiner == nullptr)
            return tsk_error_arg(TSK_ERR_ARGUMENT, "quads",
                                 "OpenSubdiv could not build a topology from these faces");
        refiner->RefineUniform(Far::TopologyRefiner::UniformOptions(levels));
        StencilFactory::Options so;
        so.generateOffsets = true;
        so.generateIntermediateLevels = false;
        so.generateControlVerts = false;
        tsk_osd* h = new tsk_osd();
        h->stencils = StencilFactory::Create(*refiner, so);
        const Far::TopologyLevel& last = refiner->GetLevel(levels);
        h->cage_vertices = vertex_count;
        h->refined_vertices = static_cast<size_t>(last.GetNumVertices());
        if (h->stencils == nullptr ||
            static_cast<size_t>(h->stencils->GetNumStencils()) != h->refined_vertices) {
            delete h;
            delete refiner;
            return tsk_error(TSK_ERR_INTERNAL,
                             "OpenSubdiv stencil table does not match the "
                             "refined level");
        }
        const int nf = last.GetNumFaces();
        h->faces.reserve(4 * static_cast<size_t>(nf));
        for (int f = 0; f < nf; ++f) {
            Far::ConstIndexArray fv = last.GetFaceVertices(f);
            if (fv.size() != 4) {
                delete h;
                delete refiner;
                return tsk_error(TSK_ERR_INTERNAL, "OpenSubdiv refined face %d has %d vertices", f,
                                 fv.size());
            }
            for (int k = 0; k < 4; ++k) h->faces.push_back(fv[k]);
        }
        delete refiner;
        *out = h;
        return TSK_OK;
    } catch (const std::bad_alloc&) {
        delete refiner;
        return tsk_error(TSK_ERR_MEMORY, "out of memory in OpenSubdiv refinement");
    } catch (const std::exception& e) {
        delete refiner;
        return tsk_error(TSK_ERR_INTERNAL, "OpenSubdiv: %s", e.what());
    } catch (...) {
        delete refiner;
        return tsk_error(TSK_ERR_INTERNAL, "OpenSubdiv: unknown exception");
    }
}

extern "C" void tsk_osd_destroy(tsk_osd* osd) {
    try {
        delete osd;
    } catch (...) {}
}

extern "C" size_t tsk_osd_vertex_count(const tsk_osd* osd) {
    return osd ? osd->refined_vertices : 0;
}
extern "C" size_t tsk_osd_face_count(const tsk_osd* osd) { return osd ? osd->faces.size() / 4 : 0; }

extern "C" tsk_status tsk_osd_faces(const tsk_osd* osd, int32_t* quads) {
    try {
        if (!osd->faces.empty()) std::memcpy(quads, osd->faces.data(), osd->faces.size() * 4);
        return TSK_OK;
    } catch (...) { return tsk_error(TSK_ERR_INTERNAL, "OpenSubdiv: unknown exception"); }
}

extern "C" tsk_status tsk_osd_apply(const tsk_osd* osd, const float* cage, float* refined) {
    try {
        apply_ctx c{osd->stencils, cage, refined};
        tsk_parallel_for(osd->refined_vertices, 4096, apply_range, &c);
        return TSK_OK;
    } catch (const std::exception& e) {
        return tsk_error(TSK_ERR_INTERNAL, "OpenSubdiv: %s", e.what());
    } catch (...) { return tsk_error(TSK_ERR_INTERNAL, "OpenSubdiv: unknown exception"); }
}
