//! Forecasts waiting for their outcome, oldest first: the queue both verifiers keep (the
//! relative service's, `relative::verify`, and the crane's, `crane::verify`).
//!
//! Bounded, so that a motion stream that never arrives cannot grow it: beyond `max` the oldest
//! is dropped and counted. Its boxes are reused once taken back, so a warm queue does not
//! allocate.

use std::collections::VecDeque;

/// Boxed items in issue order, at most `max` of them.
#[derive(Debug)]
pub struct PendingQueue<T> {
    queue: VecDeque<Box<T>>,
    spare: Vec<Box<T>>,
    max: usize,
    /// Items dropped: beyond `max`, discarded ([`Self::discard`]), or all at once by
    /// [`Self::drop_all`].
    pub dropped: u64,
}

impl<T: Default> PendingQueue<T> {
    /// A queue of at most `max` (at least 1) items.
    pub fn new(max: usize) -> Self {
        let max = max.max(1);
        Self {
            queue: VecDeque::with_capacity(max + 1),
            spare: Vec::with_capacity(max + 1),
            max,
            dropped: 0,
        }
    }

    /// A box to fill and [`Self::push`]: a reused one where there is one.
    pub fn slot(&mut self) -> Box<T> {
        self.spare.pop().unwrap_or_default()
    }

    /// Appends `item`; the oldest beyond `max` are dropped.
    pub fn push(&mut self, item: Box<T>) {
        self.queue.push_back(item);
        while self.queue.len() > self.max {
            if let Some(old) = self.queue.pop_front() {
                self.dropped += 1;
                self.spare.push(old);
            }
        }
    }

    pub fn front(&self) -> Option<&T> {
        self.queue.front().map(|b| &**b)
    }

    pub fn back_mut(&mut self) -> Option<&mut T> {
        self.queue.back_mut().map(|b| &mut **b)
    }

    /// The oldest item if it is due: its last step, `end_s(item)`, at or before `until_s`.
    /// Hand its box back with [`Self::recycle`] once used, or [`Self::discard`] if it could
    /// not be.
    pub fn pop_due(&mut self, until_s: f64, end_s: impl Fn(&T) -> f64) -> Option<Box<T>> {
        let due = self
            .queue
            .front()
            .is_some_and(|t| end_s(t) <= until_s + 1e-9);
        if due {
            self.queue.pop_front()
        } else {
            None
        }
    }

    pub fn recycle(&mut self, item: Box<T>) {
        self.spare.push(item);
    }

    /// Recycles an item that could not be used, counting it as dropped.
    pub fn discard(&mut self, item: Box<T>) {
        self.dropped += 1;
        self.spare.push(item);
    }

    /// Drops every waiting item.
    pub fn drop_all(&mut self) {
        self.dropped += self.queue.len() as u64;
        self.spare.extend(self.queue.drain(..));
    }

    pub fn len(&self) -> usize {
        self.queue.len()
    }

    pub fn is_empty(&self) -> bool {
        self.queue.is_empty()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_oldest_beyond_the_bound_are_dropped_and_boxes_are_reused() {
        let mut q = PendingQueue::<u32>::new(2);
        for i in 0..5 {
            let mut slot = q.slot();
            *slot = i;
            q.push(slot);
        }
        assert_eq!((q.len(), q.dropped, q.front()), (2, 3, Some(&3)));
        // Items "end" at their value: 3 is due at 3.0, 4 is not yet.
        assert!(q.pop_due(2.5, |&v| f64::from(v)).is_none());
        let first = q.pop_due(3.0, |&v| f64::from(v)).unwrap();
        assert!(q.pop_due(3.0, |&v| f64::from(v)).is_none());
        let at = &*first as *const u32;
        q.recycle(first);
        // The box handed back is the next slot.
        assert_eq!(&*q.slot() as *const u32, at);
        let second = q.pop_due(4.0, |&v| f64::from(v)).unwrap();
        q.discard(second);
        assert_eq!((q.len(), q.dropped), (0, 4));
        let mut slot = q.slot();
        *slot = 5;
        q.push(slot);
        q.drop_all();
        assert_eq!((q.len(), q.dropped, q.is_empty()), (0, 5, true));
    }
}
