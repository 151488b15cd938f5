#include "coordinator/job_film.h"

#include "common/farm/metrics.h"

namespace alphorn::coordinator {

JobFilm::JobFilm(const farm::JobGrid& grid, std::string checkpointPath)
    : m_grid(grid),
      m_path(std::move(checkpointPath)),
      m_merged(grid.unitCount(), false),
      m_mergedPerChunk(grid.chunkCount(), 0) {}

uint64_t JobFilm::memoryBytes(int width, int height, uint64_t unitCount) {
    // Per unit a merged flag (a bit, counted as a byte); per chunk a counter (fewer than units).
    return uint64_t(width) * uint64_t(height) * sizeof(PixelSum) + unitCount;
}

void JobFilm::startEmpty() {
    forget();
    m_film = FilmBlock(0, 0, m_grid.width(), m_grid.height());
}

void JobFilm::forget() {
    m_merged.assign(m_grid.unitCount(), false);
    m_mergedPerChunk.assign(m_grid.chunkCount(), 0);
    m_mergedCount = m_passesComplete = 0;
    m_samplesMerged = 0;
    m_checkpointedCount = 0;
    m_film = FilmBlock();
}

void JobFilm::restore(Checkpoint checkpoint, bool keepFilm) {
    forget();
    for (uint32_t i = 0; i < m_grid.unitCount(); ++i)
        if (checkpoint.merged.at(i)) countMerged(i);
    m_checkpointedCount = m_mergedCount;
    if (keepFilm) m_film = std::move(checkpoint.film);
}

uint64_t JobFilm::countMerged(uint32_t unitIndex) {
    m_merged[unitIndex] = true;
    ++m_mergedCount;
    const RenderUnit unit = m_grid.unit(unitIndex);
    const uint64_t samples =
        uint64_t(unit.tile.width()) * unit.tile.height() * (unit.passEnd - unit.passBegin);
    m_samplesMerged += samples;
    const uint32_t chunk = m_grid.chunkOf(unitIndex);
    if (++m_mergedPerChunk[chunk] == m_grid.tileCount())
        m_passesComplete += m_grid.chunkPasses(chunk);
    return samples;
}

void JobFilm::merge(uint32_t unitIndex, const FilmBlock& block) {
    if (m_merged.at(unitIndex)) fail("unit %u is merged already", unitIndex);
    m_film.add(block);
    farm::CoordinatorMetrics::unitMerged(countMerged(unitIndex));
}

void JobFilm::writeFile(const Copy& copy) const {
    writeCheckpoint(m_path, copy.film, copy.merged);
}

Checkpoint JobFilm::readFile() const {
    return readCheckpoint(m_path, m_grid.width(), m_grid.height(), m_grid.unitCount());
}

void JobFilm::checkpointWritten(uint32_t count) {
    m_checkpointError.clear();
    m_checkpointedCount = count;
    ++m_checkpointsWritten;
}

}  // namespace alphorn::coordinator
