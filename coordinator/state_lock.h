// An exclusive lock on a coordinator's state directory. Two coordinators on one directory would
// both resume its jobs and overwrite each other's checkpoints, so the second one must not start.
#pragma once

#include <string>

namespace alphorn::coordinator {

class StateDirectoryLock {
  public:
    // Creates `directory` if needed and takes the lock (flock on DIRECTORY/lock, released by
    // the kernel when the process dies). Throws Error naming the holder when another process,
    // or another lock object of this one, has it.
    explicit StateDirectoryLock(const std::string& directory);
    ~StateDirectoryLock();
    StateDirectoryLock(const StateDirectoryLock&) = delete;
    StateDirectoryLock& operator=(const StateDirectoryLock&) = delete;

  private:
    int m_fd = -1;
};

}  // namespace alphorn::coordinator
