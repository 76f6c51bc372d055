// A tiny test runner for the package's plain C# logic under mono: each check is a named Action;
// an exception fails it. Prints one line per failure and "N passed, N failed" at the end.
using System;
using System.Collections.Generic;

namespace VWorldLod.Tests
{
    public class TestFailure : Exception
    {
        public TestFailure(string message) : base(message) { }
    }

    public class TestRunner
    {
        public int Passed;
        public int Failed;
        public readonly List<string> Failures = new List<string>();

        public void Check(string name, Action test)
        {
            try
            {
                test();
                Passed++;
            }
            catch (Exception e)
            {
                Failed++;
                string message = e is TestFailure ? e.Message : e.GetType().Name + ": " + e.Message;
                Failures.Add(name);
                Console.WriteLine("FAIL " + name + ": " + message);
            }
        }

        public int Finish()
        {
            Console.WriteLine(Passed + " passed, " + Failed + " failed");
            return Failed == 0 ? 0 : 1;
        }
    }

    public static class Assert
    {
        public static void True(bool condition, string message)
        {
            if (!condition) throw new TestFailure(message);
        }

        public static void Equal<T>(T expected, T actual, string what)
        {
            if (!Equals(expected, actual)) throw new TestFailure(what + ": expected " + expected + ", got " + actual);
        }

        public static void Near(double expected, double actual, double tolerance, string what)
        {
            if (!(Math.Abs(expected - actual) <= tolerance))
                throw new TestFailure(what + ": expected " + expected.ToString("R") + ", got " + actual.ToString("R") + " (tolerance " + tolerance + ")");
        }

        public static void Contains(string needle, string haystack, string what)
        {
            if (haystack == null || !haystack.Contains(needle))
                throw new TestFailure(what + ": \"" + haystack + "\" does not contain \"" + needle + "\"");
        }

        /// <summary>Runs action, which must throw TException; returns it.</summary>
        public static TException Throws<TException>(Action action, string what) where TException : Exception
        {
            try
            {
                action();
            }
            catch (TException e)
            {
                return e;
            }
            catch (Exception e)
            {
                throw new TestFailure(what + ": expected " + typeof(TException).Name + ", got " + e.GetType().Name + ": " + e.Message);
            }
            throw new TestFailure(what + ": expected " + typeof(TException).Name + ", nothing was thrown");
        }
    }
}
