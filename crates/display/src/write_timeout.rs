//! A connection's IO with a write timeout: a write (or flush) that stays pending for longer
//! than the timeout fails with [`ErrorKind::TimedOut`], so that the connection ends and frees
//! its slot. A write stays pending when the socket's send buffer is full, which on a working
//! network means that the client has stopped reading (or vanished without closing): an event
//! stream otherwise has a snapshot to send every 500 ms and would hold the slot for ever.
//!
//! The timer runs only while a write waits; any progress stops it, so a client that reads is
//! not cut however slowly it reads, only one that takes nothing for the whole timeout. The
//! timer is made at the first wait and reset after that: a write allocates nothing.

use std::future::Future;
use std::io::{self, ErrorKind, IoSlice};
use std::pin::Pin;
use std::task::{ready, Context, Poll};
use std::time::Duration;
use tokio::io::{AsyncRead, AsyncWrite, ReadBuf};
use tokio::time::{Instant, Sleep};

/// `T` whose writes fail once one has waited for longer than `timeout`.
#[derive(Debug)]
pub(crate) struct WriteTimeout<T> {
    inner: T,
    timeout: Duration,
    /// The deadline of the write that waits; made at the first wait, then only reset.
    timer: Option<Pin<Box<Sleep>>>,
    /// Whether a write waits, i.e. whether `timer` holds its deadline.
    waiting: bool,
}

/// The error of a write that waited for longer than the timeout, so that the end of the
/// connection can be told apart from other errors (see [`is_write_stall`]).
#[derive(Debug, thiserror::Error)]
#[error("the client took nothing sent for {0:?}")]
pub(crate) struct WriteStalled(Duration);

impl<T> WriteTimeout<T> {
    pub(crate) fn new(inner: T, timeout: Duration) -> Self {
        WriteTimeout {
            inner,
            timeout,
            timer: None,
            waiting: false,
        }
    }

    /// Pass on a write's outcome: one that went through stops the timer.
    fn wrote<R>(
        &mut self,
        cx: &mut Context<'_>,
        outcome: Poll<io::Result<R>>,
    ) -> Poll<io::Result<R>> {
        match outcome {
            Poll::Pending => self.wait(cx),
            done => {
                self.waiting = false;
                done
            }
        }
    }

    /// A write (or flush) waits: start the timer unless it runs already, and fail the write
    /// once it has run out.
    fn wait<R>(&mut self, cx: &mut Context<'_>) -> Poll<io::Result<R>> {
        let timer = match &mut self.timer {
            Some(timer) if self.waiting => timer,
            Some(timer) => {
                timer.as_mut().reset(Instant::now() + self.timeout);
                timer
            }
            None => self
                .timer
                .insert(Box::pin(tokio::time::sleep(self.timeout))),
        };
        self.waiting = true;
        ready!(timer.as_mut().poll(cx));
        self.waiting = false;
        Poll::Ready(Err(io::Error::new(
            ErrorKind::TimedOut,
            WriteStalled(self.timeout),
        )))
    }
}

impl<T: AsyncRead + Unpin> AsyncRead for WriteTimeout<T> {
    fn poll_read(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &mut ReadBuf<'_>,
    ) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_read(cx, buf)
    }
}

impl<T: AsyncWrite + Unpin> AsyncWrite for WriteTimeout<T> {
    fn poll_write(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        buf: &[u8],
    ) -> Poll<io::Result<usize>> {
        let outcome = Pin::new(&mut self.inner).poll_write(cx, buf);
        self.wrote(cx, outcome)
    }

    fn poll_write_vectored(
        mut self: Pin<&mut Self>,
        cx: &mut Context<'_>,
        bufs: &[IoSlice<'_>],
    ) -> Poll<io::Result<usize>> {
        let outcome = Pin::new(&mut self.inner).poll_write_vectored(cx, bufs);
        self.wrote(cx, outcome)
    }

    fn is_write_vectored(&self) -> bool {
        self.inner.is_write_vectored()
    }

    fn poll_flush(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        // A flush that is done is no progress of the data waiting: it leaves the timer be.
        match Pin::new(&mut self.inner).poll_flush(cx) {
            Poll::Pending => self.wait(cx),
            done => done,
        }
    }

    fn poll_shutdown(mut self: Pin<&mut Self>, cx: &mut Context<'_>) -> Poll<io::Result<()>> {
        Pin::new(&mut self.inner).poll_shutdown(cx)
    }
}

/// Whether `error`, or an error it was caused by, is a [`WriteStalled`].
pub(crate) fn is_write_stall(error: &(dyn std::error::Error + 'static)) -> bool {
    let mut next = Some(error);
    while let Some(e) = next {
        let stalled = e.is::<WriteStalled>()
            || e.downcast_ref::<io::Error>()
                .and_then(io::Error::get_ref)
                .is_some_and(|inner| inner.is::<WriteStalled>());
        if stalled {
            return true;
        }
        next = e.source();
    }
    false
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::future::poll_fn;

    /// A writer that takes a write only on every `every`-th try; a wait wakes the task at
    /// once, as a socket whose client reads would. `every: None` takes nothing, ever.
    struct Trickle {
        every: Option<u32>,
        tries: u32,
    }

    impl AsyncWrite for Trickle {
        fn poll_write(
            mut self: Pin<&mut Self>,
            cx: &mut Context<'_>,
            buf: &[u8],
        ) -> Poll<io::Result<usize>> {
            self.tries += 1;
            match self.every {
                Some(every) if self.tries.is_multiple_of(every) => Poll::Ready(Ok(buf.len())),
                Some(_) => {
                    cx.waker().wake_by_ref();
                    Poll::Pending
                }
                None => Poll::Pending,
            }
        }

        fn poll_flush(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<io::Result<()>> {
            Poll::Ready(Ok(()))
        }

        fn poll_shutdown(self: Pin<&mut Self>, _: &mut Context<'_>) -> Poll<io::Result<()>> {
            Poll::Ready(Ok(()))
        }
    }

    async fn write(io: &mut WriteTimeout<Trickle>) -> io::Result<usize> {
        poll_fn(|cx| Pin::new(&mut *io).poll_write(cx, b"data: {}\n\n")).await
    }

    #[tokio::test]
    async fn a_write_that_waits_longer_than_the_timeout_fails() {
        let mut io = WriteTimeout::new(
            Trickle {
                every: None,
                tries: 0,
            },
            Duration::from_millis(20),
        );
        let error = write(&mut io)
            .await
            .expect_err("a write that never goes through");
        assert_eq!(error.kind(), ErrorKind::TimedOut);
        assert!(is_write_stall(&error), "{error}");
        let other = io::Error::new(ErrorKind::TimedOut, "another timeout");
        assert!(!is_write_stall(&other));
    }

    #[tokio::test]
    async fn writes_that_go_through_never_time_out_however_long_they_go_on() {
        let timeout = Duration::from_millis(5);
        let mut io = WriteTimeout::new(
            Trickle {
                every: Some(2),
                tries: 0,
            },
            timeout,
        );
        // Every write waits once and goes through when tried again, however late that is:
        // together the writes wait far longer than the timeout.
        let until = Instant::now() + timeout * 20;
        let mut writes = 0u64;
        while Instant::now() < until || writes < 100 {
            write(&mut io).await.expect("a write that goes through");
            writes += 1;
        }
    }
}
