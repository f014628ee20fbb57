//! Where a job is in its life: the states the queue stores and shows.

/// Where a job is in its life.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum JobState {
    /// Waiting in the queue for a machine.
    Queued,
    /// A machine is plotting it.
    Plotting,
    /// Its machine paused it (a pen change, the operator); it goes on on the same machine.
    Paused,
    /// It was plotting (or paused) when the studio stopped without ending it (a crash, a power cut): it waits for
    /// the operator to confirm the paper is still in place before it resumes, and holds its machine until then.
    Interrupted,
    /// It finished.
    Done,
    /// It ended with an error.
    Failed,
    /// The operator cancelled it.
    Cancelled,
}

impl JobState {
    /// Every state, in the order of a job's life.
    pub const ALL: [JobState; 7] = [
        JobState::Queued,
        JobState::Plotting,
        JobState::Paused,
        JobState::Interrupted,
        JobState::Done,
        JobState::Failed,
        JobState::Cancelled,
    ];

    /// The word stored in the database (and shown to the user).
    pub fn as_str(self) -> &'static str {
        match self {
            JobState::Queued => "queued",
            JobState::Plotting => "plotting",
            JobState::Paused => "paused",
            JobState::Interrupted => "interrupted",
            JobState::Done => "done",
            JobState::Failed => "failed",
            JobState::Cancelled => "cancelled",
        }
    }

    /// The state a stored word names; `None` for a word that names none.
    pub fn parse(word: &str) -> Option<JobState> {
        JobState::ALL.into_iter().find(|s| s.as_str() == word)
    }

    /// Has the job ended (done, failed or cancelled)?
    pub fn is_final(self) -> bool {
        matches!(self, JobState::Done | JobState::Failed | JobState::Cancelled)
    }

    /// Does the job hold its machine (plotting, paused, or interrupted and waiting for the operator)?
    pub fn holds_machine(self) -> bool {
        matches!(self, JobState::Plotting | JobState::Paused | JobState::Interrupted)
    }
}

impl std::fmt::Display for JobState {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_state_reads_back_from_its_word() {
        for s in JobState::ALL {
            assert_eq!(JobState::parse(s.as_str()), Some(s));
        }
        assert_eq!(JobState::parse("lost"), None);
        assert_eq!(JobState::Interrupted.to_string(), "interrupted");
    }
}
