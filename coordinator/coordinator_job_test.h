// A test fixture for the coordinator's tests that drive a whole job through Coordinator
// without sockets: a small scene in a temporary directory, the request that submits it with its
// files uploaded, and a leased unit rendered the way a worker renders it.
#pragma once

#include "common/farm/bundle.h"
#include "common/farm/convert.h"
#include "common/farm/files.h"
#include "common/farm/film_codec.h"
#include "common/farm/sha256.h"
#include "common/render/unit.h"
#include "common/scene/parser.h"
#include "common/scene/scene.h"
#include "coordinator/coordinator.h"
#include "tests/support/source_tree.h"

#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

namespace alphorn::coordinator {

namespace fs = std::filesystem;

class CoordinatorJobTest : public ::testing::Test {
  protected:
    void SetUp() override {
        m_dir = fs::temp_directory_path() / ("alphorn_coordinator_" + std::to_string(::getpid()));
        fs::remove_all(m_dir);
        fs::create_directories(m_dir / "scene");
        fs::copy_file(sourcePath("scenes/meshes/sphere.obj"), m_dir / "scene/sphere.obj");
        writeScene(R"(<integrator type="normals"/>)");
        m_options.stateDirectory = (m_dir / "state").string();
        m_options.leaseSeconds = 60;
    }
    void TearDown() override { fs::remove_all(m_dir); }

    // Writes the job's scene: the sphere seen from the same camera at `width` x `height` pixels,
    // rendered by `integrator` (its XML element), with `extra` elements (e.g. an emitter).
    void writeScene(const std::string& integrator, int width = 40, int height = 30,
                    const std::string& extra = "") {
        std::ofstream(m_dir / "scene/s.xml") << "<scene>\n  " << integrator << R"(
  <camera type="perspective">
    <transform name="toWorld"><lookat origin="3, 2, 4" target="0, 0, 0" up="0, 1, 0"/></transform>
    <integer name="width" value=")" << width << R"("/><integer name="height" value=")"
                                             << height << R"("/>
  </camera>
  <mesh type="obj"><string name="filename" value="sphere.obj"/></mesh>
  )" << extra << "\n</scene>\n";
    }

    // The sphere under a point light, rendered by progressive photon mapping: a job whose film
    // keeps the smaller radius's image.
    void writeProgressivePhotonScene() {
        writeScene(R"(<integrator type="photonmapper">
    <integer name="photonCount" value="500"/>
    <float name="surfacePhotonRadius" value="0.5"/>
    <boolean name="progressive" value="true"/>
  </integrator>)",
                   40, 30,
                   R"(<emitter type="point">
    <point name="position" value="0, 3, 0"/><color name="power" value="50, 50, 50"/>
  </emitter>)");
    }

    // Stores the scene's files in the coordinator's blob store, as `alphorn submit` uploads
    // them, and returns the request that submits it (`passes` passes of one pass per unit).
    v1::SubmitJobRequest upload(Coordinator& coordinator, uint32_t passes = 3) {
        farm::Bundle bundle = farm::gatherBundle((m_dir / "scene/s.xml").string());
        for (const auto& file : bundle.files) {
            BlobStore::Upload blob(coordinator.blobs(), file.sha256);
            blob.append(farm::readFile(file.sourcePath));
            blob.commit();
        }
        v1::SubmitJobRequest request;
        *request.mutable_bundle() = farm::toProto(bundle);
        request.mutable_settings()->set_passes(passes);
        request.mutable_settings()->set_seed(5);
        request.mutable_settings()->set_tile_size(16);
        request.mutable_settings()->set_passes_per_unit(1);
        return request;
    }

    // Renders a leased unit the way a worker does: the block's layout from the lease.
    v1::ResultChunk render(const v1::AcquireWorkResponse& lease, uint64_t workerId,
                           std::string& compressed) {
        auto scene = loadScene((m_dir / "scene/s.xml").string());
        const RenderUnit unit = farm::fromProto(lease.unit());
        FilmBlock block =
            unitBlock(unit.tile, filterBorder(*scene),
                      lease.unit().smaller_radius() ? SmallerRadius::Kept : SmallerRadius::None);
        renderUnit(*scene, 5, unit, preparePasses(*scene, 5, unit.passBegin, unit.passEnd), block);
        compressed = farm::compressFilm(block);
        v1::ResultChunk header;
        header.set_worker_id(workerId);
        header.set_lease_id(lease.lease_id());
        header.set_job_id(lease.unit().job_id());
        header.set_unit_index(lease.unit().unit_index());
        header.set_block_x0(block.x0());
        header.set_block_y0(block.y0());
        header.set_block_width(block.width());
        header.set_block_height(block.height());
        header.set_compressed_size(compressed.size());
        header.set_compressed_sha256(farm::sha256Hex(compressed));
        return header;
    }

    fs::path m_dir;
    CoordinatorOptions m_options;
};

}  // namespace alphorn::coordinator
